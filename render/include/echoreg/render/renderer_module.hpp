// Where figures are drawn: the renderer module. OpenGL through OSMesa brings Mesa's llvmpipe with
// LLVM and z3 into a process, which costs about 0.1 s at every start; so the drawing half of
// render/ (OffscreenWindow, the VTK scene) is a shared library of its own,
// libechoreg_render_gl.so, that renderScene opens with dlopen on the first figure. Commands that
// draw nothing never load it (docs/architecture.md).
#pragma once

#include "echoreg/render/image.hpp"
#include "echoreg/render/scene.hpp"

#include <filesystem>

namespace echoreg::render {

/// Where renderScene opens the renderer module: EXE_DIR/../lib/echoreg/libechoreg_render_gl.so,
/// EXE_DIR being the folder of the running executable (/proc/self/exe: a symbolic link to the
/// executable is followed to the file itself). In the build tree
/// build/release/cli/echoreg (and the tests and benchmarks beside it) finds
/// build/release/lib/echoreg/; installed, PREFIX/bin/echoreg finds PREFIX/lib/echoreg/.
std::filesystem::path rendererModulePath();

/// renderScene through the module at `modulePath` (opened once per process, kept open). Throws
/// FileError naming `modulePath` when it cannot be opened or is the renderer of another build,
/// and what renderScene throws otherwise.
RgbImage renderSceneWith(const std::filesystem::path& modulePath, const Scene& scene,
                         const FigureSize& size);

}  // namespace echoreg::render
