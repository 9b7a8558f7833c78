// A harness without libFuzzer: feeds files to its LLVMFuzzerTestOneInput once each, no mutation.
// Built in the normal build (fuzz/CMakeLists.txt), so every seed and finding in fuzz/seeds stays a
// regression test of `make test` (ctest -R fuzz_replay).
//
//   fuzz_replay_READER [--prefix BYTE] PATH...
//
// A PATH that is a folder stands for its regular files, in name order. --prefix puts one byte
// (0-255) before every following input (fuzz_mesh's kind byte for plain model files). Prints how
// many inputs ran; exits 1 when there were none, so that a test over an emptied folder fails.
// A finding ends the program as it ends the fuzzer (an uncaught exception, a crash).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  int inputs = 0;
  std::vector<std::uint8_t> prefix;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--prefix" && a + 1 < argc) {
      prefix = {static_cast<std::uint8_t>(std::stoi(argv[++a]))};
      continue;
    }
    std::vector<fs::path> files;
    if (fs::is_directory(arg)) {
      for (const auto& entry : fs::directory_iterator(arg)) {
        if (entry.is_regular_file())
          files.push_back(entry.path());
      }
      std::sort(files.begin(), files.end());
    } else if (fs::is_regular_file(arg)) {
      files.push_back(arg);
    } else {
      std::cerr << arg << ": no such file or folder\n";
      return 1;
    }
    for (const fs::path& file : files) {
      std::ifstream in(file, std::ios::binary);
      std::vector<std::uint8_t> bytes = prefix;
      bytes.insert(bytes.end(), std::istreambuf_iterator<char>(in),
                   std::istreambuf_iterator<char>());
      std::cout << file.string() << "\n" << std::flush;
      LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
      ++inputs;
    }
  }
  std::cout << inputs << " inputs replayed\n";
  return inputs > 0 ? 0 : 1;
}
