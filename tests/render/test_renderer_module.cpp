// renderScene opens the renderer module (libechoreg_render_gl) beside the executable; a missing or
// foreign module is a FileError naming its path, not a crash.
#include "echoreg/render/renderer_module.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/render/plot_figure.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace {

using echoreg::render::renderSceneWith;

echoreg::render::Scene boxPlot() {
  return echoreg::render::boxPlotScene({{"A", {1.0, 2.0, 3.0}}, {"B", {2.0, 3.0, 5.0}}}, "box",
                                       "mm", {200, 160});
}

// Runs `draw`, which must throw FileError; returns its message.
template <typename Draw>
std::string fileErrorOf(Draw draw) {
  try {
    draw();
  } catch (const echoreg::core::FileError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no FileError";
  return {};
}

TEST(RendererModule, LiesInLibEchoregBesideTheExecutablesFolder) {
  const std::filesystem::path path = echoreg::render::rendererModulePath();
  EXPECT_EQ(path.filename(), "libechoreg_render_gl.so");
  EXPECT_EQ(path.parent_path().filename(), "echoreg");
  EXPECT_EQ(path.parent_path().parent_path().filename(), "lib");
  EXPECT_TRUE(std::filesystem::exists(path)) << path;
  const echoreg::render::RgbImage image = renderSceneWith(path, boxPlot(), {200, 160});
  EXPECT_EQ(image.width, 200);
  EXPECT_EQ(image.height, 160);
  EXPECT_EQ(image.pixels.size(), 200u * 160u * 3u);
}

TEST(RendererModule, AMissingModuleIsAFileErrorNamingIt) {
  echoreg::test::TempDir dir;
  const std::string missing = dir.file("lib/echoreg/libechoreg_render_gl.so");
  const std::string message = fileErrorOf([&] { renderSceneWith(missing, boxPlot(), {200, 160}); });
  EXPECT_NE(message.find(missing), std::string::npos) << message;
  EXPECT_NE(message.find("echoreg_render_gl"), std::string::npos) << message;
}

TEST(RendererModule, AFileThatIsNotTheModuleIsRefused) {
  echoreg::test::TempDir dir;
  const std::string text = dir.file("libechoreg_render_gl.so");
  std::ofstream(text) << "not a shared object\n";
  const std::string message = fileErrorOf([&] { renderSceneWith(text, boxPlot(), {200, 160}); });
  EXPECT_NE(message.find(text), std::string::npos) << message;
  // A shared object that is some other library: opens, but has no entry points.
  const std::string other = "/lib/x86_64-linux-gnu/libz.so.1";
  if (std::filesystem::exists(other)) {
    const std::string foreign = fileErrorOf([&] { renderSceneWith(other, boxPlot(), {200, 160}); });
    EXPECT_NE(foreign.find("is not echoreg's renderer module"), std::string::npos) << foreign;
  }
}

TEST(RendererModule, BadScenesThrowAsBeforeThroughTheModule) {
  echoreg::render::Scene empty;
  EXPECT_THROW(renderSceneWith(echoreg::render::rendererModulePath(), empty, {200, 160}),
               std::invalid_argument);
}

}  // namespace
