#include "echoreg/cli/cli.hpp"

int main(int argc, char** argv) {
  return echoreg::cli::run(argc, argv);
}
