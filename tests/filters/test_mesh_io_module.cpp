// The mesh I/O module (libechoreg_mesh_io, filters/module/) opened beside the executable: found
// where the build tree and an installation put it, its entry points checked against this build,
// and a module of another build refused with a FileError naming its path.
#include "echoreg/core/error.hpp"
#include "echoreg/core/loadable_module.hpp"
#include "echoreg/filters/mesh_io.h"
#include "mesh_files.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace {

using echoreg::core::ModuleIdentity;
using echoreg::filters::detail::kMeshIoAbiSymbol;
using echoreg::filters::detail::kMeshIoReadSymbol;
using echoreg::filters::detail::kMeshIoWriteSymbol;
using echoreg::filters::detail::meshIoAbi;

ModuleIdentity identityWith(const std::string& abi) {
  return {"mesh I/O module", "echoreg_mesh_io", "reads and writes mesh files", kMeshIoAbiSymbol,
          abi};
}

TEST(MeshIoModule, LiesInLibEchoregWithItsEntryPoints) {
  const std::filesystem::path path = echoreg::core::moduleBesideExecutable("libechoreg_mesh_io.so");
  ASSERT_TRUE(std::filesystem::exists(path)) << path;
  const ModuleIdentity identity = identityWith(meshIoAbi());
  EXPECT_NE(echoreg::core::moduleSymbol(path, identity, kMeshIoReadSymbol), nullptr);
  EXPECT_NE(echoreg::core::moduleSymbol(path, identity, kMeshIoWriteSymbol), nullptr);
  // readMesh and writeMesh through it: a tetrahedron written as .vtp and read back.
  echoreg::core::TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0, 10}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  echoreg::test::TempDir dir;
  echoreg::filters::writeMesh(dir.file("t.vtp"), mesh);
  const echoreg::core::TriangleMesh back = echoreg::filters::readMesh(dir.file("t.vtp"));
  EXPECT_EQ(back.vertices.size(), 4u);
  EXPECT_EQ(back.triangles.size(), 4u);
}

TEST(MeshIoModule, AModuleOfAnotherBuildIsRefused) {
  const std::filesystem::path path = echoreg::core::moduleBesideExecutable("libechoreg_mesh_io.so");
  try {
    echoreg::core::moduleSymbol(path, identityWith("echoreg 0.0.0 / VTK 8"), kMeshIoReadSymbol);
    ADD_FAILURE() << "no FileError";
  } catch (const echoreg::core::FileError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(path.string()), std::string::npos) << message;
    EXPECT_NE(message.find("is the mesh I/O module of another build"), std::string::npos)
        << message;
    EXPECT_NE(message.find(meshIoAbi()), std::string::npos) << message;
  }
}

TEST(MeshIoModule, ErrorsInsideNameTheFileAsBefore) {
  echoreg::test::TempDir dir;
  try {
    echoreg::filters::readMesh(dir.file("missing.stl"));
    ADD_FAILURE() << "no FileError";
  } catch (const echoreg::core::FileError& e) {
    EXPECT_EQ(e.path(), dir.file("missing.stl"));
    EXPECT_EQ(e.problem(), "no such file");
  }
}

}  // namespace
