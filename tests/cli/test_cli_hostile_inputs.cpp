// Issue 15, items 8 and 13: inputs a hostile but realistic user gives, each refused with its exit
// code and a message that names the file or flag and the problem in the user's words, with
// nothing written. One table; the cases of other items live beside their features
// (test_cli_bad_input.cpp, test_cli_poses.cpp, test_cli_messages.cpp, the study tests).
#include "cli_test_support.hpp"
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

namespace echoreg::cli {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// Runs echoreg with the process's own stderr (fd 2) captured too: VTK's readers print there, not
/// on the stream the command is given.
struct Captured {
  test::CommandResult result;
  std::string processStderr;
};

Captured runCapturingStderr(const std::vector<std::string>& args, const std::string& scratch) {
  std::fflush(stderr);
  const int saved = ::dup(2);
  std::FILE* sink = std::fopen(scratch.c_str(), "w");
  ::dup2(::fileno(sink), 2);
  Captured c;
  c.result = runEchoreg(args);
  std::fflush(stderr);
  ::dup2(saved, 2);
  ::close(saved);
  std::fclose(sink);
  c.processStderr = slurp(scratch);
  return c;
}

// A closed tetrahedron (OBJ), with vertex 3 written as `third`.
std::string tetrahedronObj(const std::string& third) {
  return "v 0 0 0\nv 30 0 0\nv " + third + "\nv 0 0 30\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
}

class CliHostileInputs : public ::testing::Test {
 protected:
  void SetUp() override {
    std::ofstream(dir_.file("good.obj")) << tetrahedronObj("0 30 0");
    std::ofstream(dir_.file("nan.obj")) << tetrahedronObj("nan 30 0");
    // Found by fuzz/fuzz_mesh: a face naming vertex 9 of 4 was read out of bounds (a crash).
    std::string beyond = tetrahedronObj("0 30 0");
    beyond.replace(beyond.find("f 2 3 4"), 7, "f 2 3 9");
    std::ofstream(dir_.file("beyond.obj")) << beyond;
    // Found by fuzz/fuzz_mesh: VTK reads indented lines too, and the check did not (a face before
    // any vertex crashed); the same model, every line indented.
    std::string indented;
    for (std::size_t start = 0; start < beyond.size();) {
      const std::size_t end = beyond.find('\n', start) + 1;
      indented += "  " + beyond.substr(start, end - start);
      start = end;
    }
    std::ofstream(dir_.file("indented.obj")) << indented;
    // Found by fuzz/fuzz_mesh: a face naming texture coordinate 2222 of a file with none was read
    // out of bounds by VTK's OBJ reader (a crash); a normal beyond the file's likewise.
    std::string texture = tetrahedronObj("0 30 0");
    texture.replace(texture.find("f 1 3 2"), 7, "f 1 3 2/2222");
    std::ofstream(dir_.file("texture-beyond.obj")) << texture;
    std::ofstream(dir_.file("normal-beyond.obj"))
        << "vn 0 0 1\n" + tetrahedronObj("0 30 0") + "f 1//1 2//2 3//1\n";
    // Found by fuzz/fuzz_mesh (stop 31): a corner "1/", a slash and nothing after it, made VTK's
    // reader read a texture coordinate of a file with none (a crash).
    std::string slash = tetrahedronObj("0 30 0");
    slash.replace(slash.find("f 1 3 2"), 7, "f 1/ 3 2");
    std::ofstream(dir_.file("slash.obj")) << slash;
    std::ofstream(dir_.file("with-texture.obj"))
        << "vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nv 0 0 0\nv 30 0 0\nv 0 30 0\nv 0 0 30\n"
           "f 1/1/1 3/3/1 2/2/1\nf 1/1/1 2/2/1 4/-1/1\nf 2/2/1 3/3/1 4/1/-1\nf 3//1 1//1 4//1\n";
    // Found by fuzz/fuzz_mesh: VTK's PLY reader skips no element but vertex and face, so the rows
    // of another before the faces were read as faces (a crash in vtkPLYReader); a second vertex
    // element is read over the first.
    const std::string plyVertices =
        "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n";
    const std::string plyFaces = "element face 4\nproperty list uchar int vertex_indices\n";
    const std::string plyData =
        "0 0 0\n30 0 0\n0 30 0\n0 0 30\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 2 0 3\n";
    std::ofstream(dir_.file("extra-element.ply")) << "ply\nformat ascii 1.0\n" + plyVertices +
                                                         "element extra 2\nproperty float w\n" +
                                                         plyFaces + "end_header\n" + plyData;
    std::ofstream(dir_.file("two-vertex-elements.ply")) << "ply\nformat ascii 1.0\n" + plyVertices +
                                                               plyVertices + plyFaces +
                                                               "end_header\n" + plyData;
    // Found by fuzz/fuzz_mesh: VTK's PLY reader frees memory it never allocated for an element
    // with no properties, here after the faces (a crash in vtkPLY::ply_close under ASan).
    std::ofstream(dir_.file("no-properties.ply")) << "ply\nformat ascii 1.0\n" + plyVertices +
                                                         plyFaces + "element extra 2\n" +
                                                         "end_header\n" + plyData;
    // Found by fuzz/fuzz_mesh: vertex_indices not a list made VTK free a list it never allocated.
    std::ofstream(dir_.file("indices-not-a-list.ply"))
        << "ply\nformat ascii 1.0\n" + plyVertices +
               "element face 4\nproperty int vertex_indices\nend_header\n" + plyData;
    // Found by fuzz/fuzz_mesh: a count of 1e62 was cast to an integer (undefined behaviour).
    std::ofstream(dir_.file("huge-count.ply"))
        << "ply\nformat ascii 1.0\nelement vertex 1e62\nproperty float x\nproperty float y\n"
           "property float z\n" +
               plyFaces + "end_header\n" + plyData;
    std::ofstream(dir_.file("empty.stl")) << "";
    // Found by fuzz/fuzz_mesh: VTK 9.1's PLY reader crashed (a null pointer) on this header.
    std::ofstream(dir_.file("misspelt.ply"))
        << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           "propert} float z\nelement face 4\nproperty list uchar int vertex_indices\n"
           "end_header\n0 0 0\n30 0 0\n0 30 0\n0 0 30\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 2 0 3\n";
    // Found by fuzz/fuzz_mesh: VTK's STL reader allocated what a binary header claims (80 bytes,
    // then a count of 10^9 triangles) before reading.
    {
      std::string stl(80, ' ');
      stl += std::string("\x00\xca\x9a\x3b", 4) + std::string(50, '\0');
      std::ofstream(dir_.file("claims.stl"), std::ios::binary) << stl;
    }
    // ... and on a face line with too few numbers.
    std::ofstream(dir_.file("short-face.ply"))
        << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           "property float z\nelement face 4\nproperty list uchar int vertex_indices\n"
           "end_header\n0 0 0\n30 0 0\n0 30 0\n0 0 30\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 2\n";
    // Found by fuzz/fuzz_mesh (stop 32): no vertices and a face row longer than its list; VTK
    // frees memory it never allocated.
    std::ofstream(dir_.file("no-vertices.ply"))
        << "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
           "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
           "end_header\n0 vertex_index\n";
    // Found by fuzz/fuzz_mesh (stop 33): a list VTK does not read in an ASCII file (a crash).
    std::ofstream(dir_.file("unused-list.ply"))
        << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           "property float z\nelement face 1\nproperty list uchar int other\n"
           "property list uchar int vertex_indices\nend_header\n0 0 0\n0 30 0\n0 0 30\n30 0 0\n"
           "1 0 3 0 1 3\n";
    // Found by fuzz/fuzz_mesh: LeakSanitizer, what VTK read of a header with two format lines.
    std::ofstream(dir_.file("two-formats.ply"))
        << "ply\nformat ascii 1.0\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
           "property float y\nproperty float z\nelement face 4\n"
           "property list uchar int vertex_indices\nend_header\n0 0 0\n30 0 0\n0 30 0\n"
           "0 0 30\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 2 0 3\n";
    // Binary PLY faces were not checked: one naming vertex 9 of 4 was read out of bounds by VTK,
    // and a file ending before its rows.
    {
      const std::string header =
          "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
          "property float y\nproperty float z\nelement face 4\n"
          "property list uchar int vertex_indices\nend_header\n";
      std::string data;
      for (const float v : {0.f, 0.f, 0.f, 30.f, 0.f, 0.f, 0.f, 30.f, 0.f, 0.f, 0.f, 30.f})
        data.append(reinterpret_cast<const char*>(&v), 4);
      const auto faces = [&](std::int32_t last) {
        std::string bytes;
        const std::int32_t corners[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, last}};
        for (const auto& face : corners) {
          bytes += '\3';
          bytes.append(reinterpret_cast<const char*>(face), 12);
        }
        return bytes;
      };
      std::ofstream(dir_.file("good-binary.ply"), std::ios::binary) << header << data << faces(3);
      std::ofstream(dir_.file("beyond-binary.ply"), std::ios::binary) << header << data << faces(9);
      std::string cut = header + data + faces(3);
      cut.resize(cut.size() - 5);
      std::ofstream(dir_.file("cut-binary.ply"), std::ios::binary) << cut;
    }
    // detect --params files (fuzz/fuzz_params): a bad value named with its key, a whole number
    // beyond an int (it was wrapped round to 7), the JSON reader's message without its codes.
    std::ofstream(dir_.file("speed.json")) << R"({"speed-of-sound": -1450})";
    std::ofstream(dir_.file("wide.json")) << R"({"envelope-window": 4294967303})";
    std::ofstream(dir_.file("broken-params.json")) << R"({"envelope": )";
    // Study manifests (fuzz/fuzz_manifest): a bone name is a part of its result files' names and a
    // JSON pointer; a manifest that is not an object, or whose format is not a string, threw the
    // JSON library's message.
    for (const auto& [folder, manifest] : std::vector<std::pair<std::string, std::string>>{
             {"bone-path", R"({"format": "echoreg-study", "bones": {"../escape": {}}})"},
             {"bone-tilde", R"({"format": "echoreg-study", "bones": {"a~b": {}}})"},
             {"format-number", R"({"format": 1, "bones": {"femur": {}}})"},
             {"array-study", "[1, 2]"}}) {
      fs::create_directory(dir_.file(folder));
      std::ofstream(dir_.file(folder + "/study.json")) << manifest;
    }
    // ASCII STL: a facet of four vertices, a NaN vertex, no endsolid ("holds no triangles" or a
    // NaN read as a number, before).
    const auto facet = [](const std::string& vertices) {
      return "facet normal 0 0 1\nouter loop\n" + vertices + "endloop\nendfacet\n";
    };
    const std::string triangle = "vertex 0 0 0\nvertex 30 0 0\nvertex 0 30 0\n";
    std::ofstream(dir_.file("good.stl"))
        << "solid t\n"
        << facet(triangle) << facet("vertex 0 0 0\nvertex 0 0 30\nvertex 30 0 0\n")
        << facet("vertex 30 0 0\nvertex 0 0 30\nvertex 0 30 0\n")
        << facet("vertex 0 30 0\nvertex 0 0 30\nvertex 0 0 0\n") << "endsolid t\n";
    std::ofstream(dir_.file("four-corners.stl"))
        << "solid t\n"
        << facet(triangle + "vertex 0 0 30\n") << "endsolid t\n";
    std::ofstream(dir_.file("nan.stl"))
        << "solid t\n"
        << facet("vertex 0 0 0\nvertex nan 0 0\nvertex 0 30 0\n") << "endsolid t\n";
    std::ofstream(dir_.file("no-end.stl")) << "solid t\n" << facet(triangle);
    std::ofstream(dir_.file("points.csv")) << "x,y,z\n5,5,0\n5,0,5\n0,5,5\n10,10,10\n";
    core::TransformFile toCt;
    toCt.from = "Femur";
    toCt.to = "CT";
    toCt.matrix = Eigen::Matrix4d::Identity();
    core::writeTransformFile(dir_.file("FemurToCT.json"), toCt, false);
    std::ofstream(dir_.file("truncated.json")) << "{\"from\": \"Femur\", \"matrix\": [[1, 0";
    std::ofstream(dir_.file("overflow.json"))
        << "{\"matrix\": [[1e999, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}";
    std::ofstream(dir_.file("null-type.mrk.json"))
        << R"({"markups": [{"type": null, "controlPoints": [{"label": "a", "position": [1, 2, 3]}]}]})";
    fs::create_directory(dir_.file("a-folder.json"));
    std::ofstream(dir_.file("calibration.json"))
        << R"({"sphere_center_mm": [0, 0, 0], "sphere_radius_mm": null, "shots": []})";
    core::SequenceWriteOptions raw;
    raw.compress = false;
    core::writeSequence(test::makeDemoSweep({8}), dir_.file("capture.igs.mha"), raw);
  }

  struct Case {
    std::vector<std::string> args;
    int exitCode;
    std::string words;  ///< must appear on the command's stderr
  };

  // The case's exit code and words, nothing written, no raw library text on either stderr.
  void expectRefused(const Case& c) {
    std::vector<std::string> args = c.args;
    for (std::string& a : args) {
      if (a.rfind("@", 0) == 0)
        a = dir_.file(a.substr(1));
    }
    std::string words = c.words;
    for (std::size_t at = words.find('@'); at != std::string::npos; at = words.find('@', at)) {
      const std::size_t end = words.find_first_of(":\" ", at);
      const std::string name = words.substr(at + 1, end - at - 1);
      words.replace(at, end - at, dir_.file(name));
      at += dir_.file(name).size();
    }
    const Captured run = runCapturingStderr(args, dir_.file("stderr.txt"));
    const std::string where = "echoreg " + fmt(c.args) + "\n" + run.result.err;
    EXPECT_EQ(run.result.exitCode, c.exitCode) << where;
    EXPECT_NE(run.result.err.find(words), std::string::npos)
        << "expected \"" << words << "\" in " << where;
    for (const char* raw : {"json.exception", "basic_filebuf", "bad_alloc", "179769313",
                            "vtkSTLReader", "vtkOBJReader", "ERR|", "\x1b["}) {
      EXPECT_EQ(run.result.err.find(raw), std::string::npos) << raw << " in " << where;
      EXPECT_EQ(run.processStderr.find(raw), std::string::npos)
          << raw << " on the process's stderr: " << run.processStderr;
    }
    EXPECT_FALSE(fs::exists(dir_.file("out.png"))) << where;
    EXPECT_FALSE(fs::exists(dir_.file("out.jpg"))) << where;
    EXPECT_FALSE(fs::exists(dir_.file("out.json"))) << where;
    EXPECT_FALSE(fs::exists(dir_.file("out.vtp"))) << where;
    EXPECT_FALSE(fs::exists(dir_.file("out.csv"))) << where;
    for (const char* name : {"out.png", "out.jpg", "out.json", "out.vtp", "out.csv"})
      fs::remove(dir_.file(name));  // one case's failure does not fail the next
  }

  static std::string fmt(const std::vector<std::string>& args) {
    std::string text;
    for (const std::string& a : args)
      text += a + " ";
    return text;
  }

  test::TempDir dir_;
};

TEST_F(CliHostileInputs, TheGoodInputsOfTheTableAreAccepted) {
  const auto r = runEchoreg({"figure", "registration", "--model", dir_.file("good.obj"), "--points",
                             dir_.file("points.csv"), "--transform", dir_.file("FemurToCT.json"),
                             "--out", dir_.file("good.png")});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(fs::is_regular_file(dir_.file("good.png")));
  // The binary PLY the checks read value by value, as written, with its faces within the file.
  const auto binary = runEchoreg({"figure", "registration", "--model", dir_.file("good-binary.ply"),
                                  "--points", dir_.file("points.csv"), "--transform",
                                  dir_.file("FemurToCT.json"), "--out", dir_.file("binary.png")});
  ASSERT_EQ(binary.exitCode, 0) << binary.err;
  EXPECT_TRUE(fs::is_regular_file(dir_.file("binary.png")));
  // The ASCII STL the checks read line by line.
  const auto stl = runEchoreg({"figure", "registration", "--model", dir_.file("good.stl"),
                               "--points", dir_.file("points.csv"), "--transform",
                               dir_.file("FemurToCT.json"), "--out", dir_.file("stl.png")});
  ASSERT_EQ(stl.exitCode, 0) << stl.err;
  EXPECT_TRUE(fs::is_regular_file(dir_.file("stl.png")));
  // An OBJ whose faces name texture coordinates and normals it has (one counted from the end).
  const auto uv = runEchoreg({"figure", "registration", "--model", dir_.file("with-texture.obj"),
                              "--points", dir_.file("points.csv"), "--transform",
                              dir_.file("FemurToCT.json"), "--out", dir_.file("uv.png")});
  ASSERT_EQ(uv.exitCode, 0) << uv.err;
  EXPECT_TRUE(fs::is_regular_file(dir_.file("uv.png")));
}

TEST_F(CliHostileInputs, EachIsRefusedNamingTheFileOrFlagWithNothingWritten) {
  const std::vector<std::string> figure{"figure",      "registration", "--points",
                                        "@points.csv", "--transform",  "@FemurToCT.json"};
  auto figureWith = [&figure](std::vector<std::string> more) {
    std::vector<std::string> args = figure;
    args.insert(args.end(), more.begin(), more.end());
    return args;
  };
  const std::vector<Case> cases{
      // Item 8: a NaN vertex was read as a point (a spike in the model and the figure).
      {figureWith({"--model", "@nan.obj", "--out", "@out.png"}), 1,
       "@nan.obj: line 3: vertex 3 \"v nan 30 0\" is not three finite numbers: a damaged model"},
      {figureWith({"--model", "@beyond.obj", "--out", "@out.png"}), 1,
       "@beyond.obj: line 7: face \"f 2 3 9\": \"9\" is not a vertex number from 1 to 4"},
      {figureWith({"--model", "@extra-element.ply", "--out", "@out.png"}), 1,
       "@extra-element.ply: line 7: element extra (2 rows) comes before the face element: VTK "
       "reads only the vertex and face elements and would read its rows as theirs"},
      {figureWith({"--model", "@two-vertex-elements.ply", "--out", "@out.png"}), 1,
       "@two-vertex-elements.ply: line 7: a second vertex element"},
      {figureWith({"--model", "@no-properties.ply", "--out", "@out.png"}), 1,
       "@no-properties.ply: line 9: element extra has no properties: VTK's PLY reader crashes on "
       "such an element"},
      {figureWith({"--model", "@indices-not-a-list.ply", "--out", "@out.png"}), 1,
       "@indices-not-a-list.ply: line 9: the face element has no vertex_indices list"},
      {figureWith({"--model", "@huge-count.ply", "--out", "@out.png"}), 1,
       "@huge-count.ply: line 3: element vertex claims 1e62 rows, more than VTK's PLY reader can "
       "count"},
      {figureWith({"--model", "@indented.obj", "--out", "@out.png"}), 1,
       "@indented.obj: line 7: face \"  f 2 3 9\": \"9\" is not a vertex number from 1 to 4"},
      {figureWith({"--model", "@texture-beyond.obj", "--out", "@out.png"}), 1,
       "@texture-beyond.obj: line 5: face \"f 1 3 2/2222\": \"2/2222\" names a texture "
       "coordinate or normal the file does not have (0 texture coordinates, 0 normals)"},
      {figureWith({"--model", "@slash.obj", "--out", "@out.png"}), 1,
       "@slash.obj: line 5: face \"f 1/ 3 2\": \"1/\" is not a corner (a vertex number, then "
       "/texture, //normal or /texture/normal)"},
      {figureWith({"--model", "@normal-beyond.obj", "--out", "@out.png"}), 1,
       "@normal-beyond.obj: line 10: face \"f 1//1 2//2 3//1\": \"2//2\" names a texture "
       "coordinate or normal the file does not have (0 texture coordinates, 1 normals)"},
      // Item 8: a negative sphere radius was drawn.
      {figureWith({"--model", "@good.obj", "--point-radius", "-1", "--out", "@out.png"}), 2,
       "--point-radius: must be a finite number > 0, got -1"},
      {figureWith({"--model", "@good.obj", "--green-below", "6", "--out", "@out.png"}), 1,
       "--red-above 5 must be above --green-below 6"},
      // Item 8: PNG bytes were written under a .jpg name.
      {figureWith({"--model", "@good.obj", "--out", "@out.jpg"}), 1,
       "--out: figures are written as PNG: give a name ending in .png, got \"@out.jpg\""},
      {figureWith({"--model", "@misspelt.ply", "--out", "@out.png"}), 1,
       "@misspelt.ply: line 6: \"propert} float z\" is not a PLY header line"},
      {figureWith({"--model", "@claims.stl", "--out", "@out.png"}), 1,
       "@claims.stl: a binary STL whose header counts 1000000000 triangles (50000000084 bytes), "
       "but "
       "the file holds 134 bytes"},
      {figureWith({"--model", "@short-face.ply", "--out", "@out.png"}), 1,
       "@short-face.ply: line 17: element face: \"3 2\" has too few numbers"},
      {figureWith({"--model", "@no-vertices.ply", "--out", "@out.png"}), 1,
       "@no-vertices.ply: line 3: the vertex element has no rows"},
      {figureWith({"--model", "@unused-list.ply", "--out", "@out.png"}), 1,
       "@unused-list.ply: line 7: element face has a list property other that VTK does not read"},
      {figureWith({"--model", "@four-corners.stl", "--out", "@out.png"}), 1,
       "@four-corners.stl: line 7: expected \"endloop\", found \"vertex 0 0 30\""},
      {figureWith({"--model", "@nan.stl", "--out", "@out.png"}), 1,
       "@nan.stl: line 5: expected \"vertex X Y Z\" of three finite numbers"},
      {figureWith({"--model", "@no-end.stl", "--out", "@out.png"}), 1,
       "@no-end.stl: line 9: expected \"endsolid\", found the end of the file"},
      {figureWith({"--model", "@two-formats.ply", "--out", "@out.png"}), 1,
       "@two-formats.ply: line 3: a second format line"},
      {figureWith({"--model", "@beyond-binary.ply", "--out", "@out.png"}), 1,
       "@beyond-binary.ply: binary data: face 4 names vertex 9, not one from 0 to 3"},
      {figureWith({"--model", "@cut-binary.ply", "--out", "@out.png"}), 1,
       "@cut-binary.ply: binary data: the file ends within element face (row 4 of 4)"},
      // Item 13: 15 lines of coloured VTK log came before "holds no triangles".
      {figureWith({"--model", "@empty.stl", "--out", "@out.png"}), 1,
       "@empty.stl: holds no triangles"},
      // Item 13: nlohmann's codes, a number overflow, a folder read as a file.
      {{"figure", "registration", "--model", "@good.obj", "--points", "@points.csv", "--transform",
        "@truncated.json", "--out", "@out.png"},
       1,
       "@truncated.json: is not valid JSON: syntax error while parsing array - unexpected end of "
       "input; expected ']' (line 1, column 35)"},
      {{"figure", "registration", "--model", "@good.obj", "--points", "@points.csv", "--transform",
        "@overflow.json", "--out", "@out.png"},
       1,
       "@overflow.json: is not valid JSON: a number too large for a double: 1e999"},
      {{"figure", "registration", "--model", "@good.obj", "--points", "@points.csv", "--transform",
        "@a-folder.json", "--out", "@out.png"},
       1,
       "@a-folder.json: is a folder, expected a JSON file"},
      {{"landmarks", "--capture", "@capture.igs.mha", "--stylus-tip-to-stylus", "@FemurToCT.json",
        "--landmarks", "@null-type.mrk.json", "--out", "@out.json"},
       1,
       "@null-type.mrk.json: holds a value of the wrong type for a 3D Slicer markups file: type "
       "must be string, but is null"},
      {{"figure", "calibration", "--calibration", "@calibration.json", "--out", "@out.png"},
       1,
       "@calibration.json: sphere_radius_mm is not a finite number >= 0, got null"},
      // Item 13: "mm per sample must be > 0" for a speed of sound of 1e308.
      {{"register", "--model", "@good.obj", "--points", "@points.csv", "--speed-of-sound", "1e308",
        "--out", "@out.json"},
       2,
       "--speed-of-sound: must be a number from 1000 to 2000, got 1e308"},
      // Item 4: segment's --decimate through the project's validators (CLI11's said "Value 2.5
      // not in range" or could not convert it).
      {{"segment", "--dicom", "@a-folder.json", "--seed", "0", "0", "0", "--decimate", "2.5",
        "--out", "@out.vtp"},
       2,
       "--decimate: must be a whole number from 0 to 100000000, got 2.5"},
      {{"pivot", "--capture", "@capture.igs.mha", "--max-rms", "nan", "--out", "@out.json"},
       2,
       "--max-rms: must be a finite number > 0, got nan"},
      // The previous stop's "noticed": detect's bad values did not name the flag (or the file).
      // ... and now the flag's range is checked where it is parsed, as register's and calibrate's.
      {{"detect", "@capture.igs.mha", "--speed-of-sound", "0", "--out", "@out.csv"},
       2,
       "--speed-of-sound: must be a number from 1000 to 2000, got 0"},
      {{"detect", "@capture.igs.mha", "--params", "@speed.json", "--out", "@out.csv"},
       1,
       "@speed.json: parameter \"speed-of-sound\" = -1450: speed of sound must be between 1000 "
       "and 2000 m/s"},
      {{"detect", "@capture.igs.mha", "--params", "@wide.json", "--out", "@out.csv"},
       1,
       "@wide.json: parameter \"envelope-window\" must be a whole number, found 4294967303"},
      {{"detect", "@capture.igs.mha", "--params", "@broken-params.json", "--out", "@out.csv"},
       1,
       "@broken-params.json: is not valid JSON: syntax error while parsing value"},
      {{"study", "run", "@bone-path"},
       1,
       "@bone-path/study.json: bones: \"../escape\" is not a bone name"},
      {{"study", "run", "@bone-tilde"},
       1,
       "@bone-tilde/study.json: bones: \"a~b\" is not a bone name"},
      {{"study", "run", "@format-number"},
       1,
       "@format-number/study.json: is not an echoreg study manifest"},
      {{"study", "run", "@array-study"},
       1,
       "@array-study/study.json: is not an echoreg study manifest"},
      // Item 12: lengths in samples longer than the record (the envelope window of a billion
      // samples took 24 GB until the kernel killed it) and a window beyond it (1e9 mm was cast to
      // an int out of its range, then refused as "processing window must have min < max").
      {{"detect", "@capture.igs.mha", "--envelope-window", "1000000000", "--out", "@out.csv"},
       1,
       "@capture.igs.mha: the envelope window (1000000000 samples) is longer than the whole "},
      {{"detect", "@capture.igs.mha", "--envelope", "hilbert", "--smoothing", "1000000000", "--out",
        "@out.csv"},
       1,
       "@capture.igs.mha: the envelope's smoothing (1000000000 samples) is longer than the whole "},
      {{"detect", "@capture.igs.mha", "--window-mm", "1e9", "2e9", "--out", "@out.csv"},
       1,
       "@capture.igs.mha: the processing window (1e+09 to 2e+09 mm) starts beyond the record, "
       "whose last sample lies at "},
      // Item 12: register with more points than it takes.
      {{"register", "--model", "@good.obj", "--points", "@points.csv", "--initial",
        "@FemurToCT.json", "--max-points", "3", "--out", "@out.json"},
       1,
       "--points @points.csv gives 4 points, more than --max-points 3"}};
  for (const Case& c : cases)
    expectRefused(c);
}

// Item 13: a header value that is wrong says it came from the header (a speed of sound of 1e308
// reached the detector as "mm per sample must be > 0").
TEST_F(CliHostileInputs, ImplausibleHeaderValuesSayTheyCameFromTheHeader) {
  const std::string good = slurp(dir_.file("capture.igs.mha"));
  const std::vector<std::pair<std::string, std::string>> cases{{"EchoregSpeedOfSoundMps", "1e308"},
                                                               {"EchoregSamplingFrequencyHz", "0"},
                                                               {"EchoregDelayS", "1e300"}};
  for (const auto& [key, value] : cases) {
    std::string bytes = good;
    const std::size_t at = bytes.find(key + " = ");
    ASSERT_NE(at, std::string::npos) << key;
    const std::size_t end = bytes.find('\n', at);
    bytes.replace(at, end - at, key + " = " + value);
    const std::string capture = dir_.file("header.igs.mha");
    std::ofstream(capture, std::ios::binary) << bytes;
    for (const std::string& command : {std::string("info"), std::string("detect")}) {
      std::vector<std::string> args{command, capture};
      if (command == "detect")
        args.insert(args.end(), {"--out", dir_.file("out.csv")});
      const auto r = runEchoreg(args);
      EXPECT_EQ(r.exitCode, 1) << r.err;
      EXPECT_NE(r.err.find(capture + ": '" + key + "' = " + value +
                           " in the capture's header is not a plausible "),
                std::string::npos)
          << r.err;
      EXPECT_EQ(r.err.find("mm per sample"), std::string::npos) << r.err;
      EXPECT_FALSE(fs::exists(dir_.file("out.csv")));
    }
  }
}

}  // namespace
}  // namespace echoreg::cli
