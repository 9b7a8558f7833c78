#include "echoreg/render/offscreen.hpp"

#include <GL/osmesa.h>

#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkImageData.h>
#include <vtkLogger.h>
#include <vtkObjectFactory.h>
#include <vtkOutputWindow.h>
#include <vtkPointData.h>
#include <vtkRenderer.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowToImageFilter.h>

#include <cstring>
#include <iostream>
#include <stdexcept>

// GLEW (inside VTK) looks OpenGL functions up with glXGetProcAddressARB. Without X there is no
// GLX context, so the renderer module exports its own versions that ask OSMesa. Opened with
// dlopen, the module comes first in its own lookup scope, ahead of libGLX (which must therefore
// not be in the executable's global scope: nothing outside the module links VTK's GL libraries),
// and libOSMesa is linked before VTK's GL libraries so that direct gl* calls resolve to Mesa.
extern "C" {
__attribute__((visibility("default"))) void (*glXGetProcAddressARB(const unsigned char* name))() {
  return reinterpret_cast<void (*)()>(OSMesaGetProcAddress(reinterpret_cast<const char*>(name)));
}
__attribute__((visibility("default"))) void (*glXGetProcAddress(const unsigned char* name))() {
  return reinterpret_cast<void (*)()>(OSMesaGetProcAddress(reinterpret_cast<const char*>(name)));
}
}

namespace echoreg::render {

namespace {

// Forwards VTK's messages to stderr except the one that the OSMesa route always triggers
// ("GLEW could not be initialized": the GLX half of glewInit; rendering works).
class FilteringOutputWindow : public vtkOutputWindow {
 public:
  static FilteringOutputWindow* New();
  vtkTypeMacro(FilteringOutputWindow, vtkOutputWindow)
  void DisplayText(const char* text) override {
    if (text == nullptr || std::strstr(text, "GLEW could not be initialized") != nullptr)
      return;
    std::cerr << text;
  }
};
vtkStandardNewMacro(FilteringOutputWindow)

void installOutputFilter() {
  static bool installed = false;
  if (installed)
    return;
  // VTK's error macros go to the log (loguru, printed on stderr) and to the output window; the
  // log's printing is turned off and the output window prints, minus that one message.
  vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
  vtkNew<FilteringOutputWindow> window;
  vtkOutputWindow::SetInstance(window);
  installed = true;
}

void markCurrent(vtkObject*, unsigned long, void*, void* callData) {
  if (callData != nullptr)
    *static_cast<bool*>(callData) = true;
}

}  // namespace

struct OffscreenWindow::Impl {
  int width = 0;
  int height = 0;
  OSMesaContext context = nullptr;
  std::vector<std::uint8_t> buffer;
  vtkSmartPointer<vtkGenericOpenGLRenderWindow> window;
};

OffscreenWindow::OffscreenWindow(int width, int height) : impl_(std::make_unique<Impl>()) {
  if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    throw std::invalid_argument("OffscreenWindow: size " + std::to_string(width) + " x " +
                                std::to_string(height) + " outside 16..8192");
  }
  installOutputFilter();
  impl_->width = width;
  impl_->height = height;
  const int attributes[] = {OSMESA_FORMAT,
                            OSMESA_RGBA,
                            OSMESA_DEPTH_BITS,
                            24,
                            OSMESA_STENCIL_BITS,
                            8,
                            OSMESA_ACCUM_BITS,
                            0,
                            OSMESA_PROFILE,
                            OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION,
                            3,
                            OSMESA_CONTEXT_MINOR_VERSION,
                            2,
                            0};
  impl_->context = OSMesaCreateContextAttribs(attributes, nullptr);
  if (impl_->context == nullptr) {
    throw std::runtime_error("OSMesa could not create an OpenGL 3.2 core context (libOSMesa)");
  }
  impl_->buffer.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4, 0);
  if (OSMesaMakeCurrent(impl_->context, impl_->buffer.data(), GL_UNSIGNED_BYTE, width, height) ==
      0) {
    OSMesaDestroyContext(impl_->context);
    throw std::runtime_error("OSMesa could not make its context current");
  }
  impl_->window = vtkSmartPointer<vtkGenericOpenGLRenderWindow>::New();
  impl_->window->SetSize(width, height);
  impl_->window->SetOwnContext(false);
  impl_->window->SetIsCurrent(true);
  impl_->window->SetReadyForRendering(true);
  impl_->window->SetMultiSamples(0);
  impl_->window->SetForceMaximumHardwareLineWidth(1.0f);
  // A white background under every panel, so that parts no renderer covers are not black.
  vtkNew<vtkRenderer> background;
  background->SetBackground(1, 1, 1);
  background->SetViewport(0, 0, 1, 1);
  impl_->window->AddRenderer(background);
  vtkNew<vtkCallbackCommand> isCurrent;
  isCurrent->SetCallback(markCurrent);
  impl_->window->AddObserver(vtkCommand::WindowIsCurrentEvent, isCurrent);
}

OffscreenWindow::~OffscreenWindow() {
  if (impl_->window) {
    // VTK releases the window's OpenGL objects in the current context: make it this window's, or
    // another window's objects of the same names go instead (found with two windows alive).
    OSMesaMakeCurrent(impl_->context, impl_->buffer.data(), GL_UNSIGNED_BYTE, impl_->width,
                      impl_->height);
    impl_->window->Finalize();
    impl_->window = nullptr;
  }
  if (impl_->context != nullptr)
    OSMesaDestroyContext(impl_->context);
}

int OffscreenWindow::width() const {
  return impl_->width;
}
int OffscreenWindow::height() const {
  return impl_->height;
}
vtkRenderWindow* OffscreenWindow::window() {
  return impl_->window;
}

vtkRenderer* OffscreenWindow::addRenderer(double xmin, double ymin, double xmax, double ymax) {
  vtkNew<vtkRenderer> renderer;
  renderer->SetViewport(xmin, ymin, xmax, ymax);
  impl_->window->AddRenderer(renderer);
  return renderer;
}

RgbImage OffscreenWindow::capture() {
  OSMesaMakeCurrent(impl_->context, impl_->buffer.data(), GL_UNSIGNED_BYTE, impl_->width,
                    impl_->height);
  impl_->window->Render();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(impl_->window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->ShouldRerenderOff();
  grab->Update();
  vtkImageData* image = grab->GetOutput();
  int dims[3];
  image->GetDimensions(dims);
  RgbImage out;
  out.width = dims[0];
  out.height = dims[1];
  out.pixels.resize(static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) * 3);
  auto* scalars = vtkUnsignedCharArray::SafeDownCast(image->GetPointData()->GetScalars());
  if (scalars == nullptr || scalars->GetNumberOfComponents() != 3) {
    throw std::runtime_error("rendering returned no RGB image");
  }
  const std::size_t row = static_cast<std::size_t>(dims[0]) * 3;
  for (int y = 0; y < dims[1]; ++y) {  // VTK's rows start at the bottom
    std::memcpy(out.pixels.data() + static_cast<std::size_t>(y) * row,
                scalars->GetPointer(0) + static_cast<std::size_t>(dims[1] - 1 - y) * row, row);
  }
  return out;
}

}  // namespace echoreg::render
