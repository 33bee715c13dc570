#include <gtest/gtest.h>

#include "solver/eigen_blocking.h"

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  // The tests run the solvers as the CLI does (MakeContext pins the same):
  // Eigen's blocking pinned and its own threading off. A product Eigen
  // shares among OpenMP threads rounds otherwise than on one, and a restart
  // beside others widens its loops when their threads are lent to it
  // (solver/side_by_side.h), at a moment that depends on the machine's load:
  // unpinned, the same solve could end in other lobes from run to run.
  shadowsg::PinEigenBlocking();
  return RUN_ALL_TESTS();
}
