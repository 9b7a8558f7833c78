// Writes the demo sweep (tests/support/demo_capture.hpp) to a PLUS sequence file.
#include "demo_capture.hpp"

#include "echoreg/core/error.hpp"

#include <iostream>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_demo_capture OUT.igs.mha\n";
    return 2;
  }
  try {
    echoreg::writeSequence(echoreg::test::makeDemoSweep({}), argv[1]);
    std::cout << "demo capture: " << argv[1] << "\n";
  } catch (const std::exception& e) {
    std::cerr << "make_demo_capture: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
