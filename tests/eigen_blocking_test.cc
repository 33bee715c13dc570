// PinEigenBlocking (solver/eigen_blocking.h): a product rounds the same way
// whatever cache sizes the CPU reported before the pin and however many
// threads Eigen was given, and every subcommand's context pins both.
#include "solver/eigen_blocking.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "pipeline/cli_common.h"

namespace shadowsg {
namespace {

// A Gram matrix of the dictionary's shape (fit points x atoms, summed over
// the points), after Eigen was told the caches of some CPU.
Eigen::MatrixXf GramAfterReported(const Eigen::MatrixXf& a, std::ptrdiff_t l1, std::ptrdiff_t l2, std::ptrdiff_t l3,
                                  bool pin) {
  Eigen::setCpuCacheSizes(l1, l2, l3);
  if (pin) PinEigenBlocking();
  return a.transpose() * a;
}

TEST(EigenBlocking, ProductsRoundTheSameWhateverTheCpuReports) {
  srand(3);
  const Eigen::MatrixXf a = Eigen::MatrixXf::Random(6000, 200);
  // The hazard: unpinned, two CPUs' caches give two roundings of one product.
  const Eigen::MatrixXf big = GramAfterReported(a, 64 << 10, 1 << 20, 32 << 20, false);
  const Eigen::MatrixXf small = GramAfterReported(a, 32 << 10, 256 << 10, 8 << 20, false);
  EXPECT_GT((big - small).cwiseAbs().maxCoeff(), 0.0f);
  // Pinned: one rounding.
  const Eigen::MatrixXf big_pinned = GramAfterReported(a, 64 << 10, 1 << 20, 32 << 20, true);
  const Eigen::MatrixXf small_pinned = GramAfterReported(a, 32 << 10, 256 << 10, 8 << 20, true);
  EXPECT_EQ((big_pinned - small_pinned).cwiseAbs().maxCoeff(), 0.0f);
  EXPECT_EQ(Eigen::l1CacheSize(), kPinnedL1Cache);
  EXPECT_EQ(Eigen::l2CacheSize(), kPinnedL2Cache);
  EXPECT_EQ(Eigen::l3CacheSize(), kPinnedL3Cache);
}

// Eigen blocks a product it shares among threads for that (on one thread it
// evens the depth blocks out, on several it does not: 256 against 288 for a
// depth of 1000 here), so one thread and two round it differently; pinned,
// Eigen keeps to one thread and one rounding.
TEST(EigenBlocking, ProductsRoundTheSameWhateverTheThreadCount) {
  srand(4);
  const Eigen::MatrixXf a = Eigen::MatrixXf::Random(1000, 200);
  const int saved = Eigen::nbThreads();
  PinEigenBlocking();
  const Eigen::MatrixXf one = a.transpose() * a;
  Eigen::setNbThreads(2);
  const Eigen::MatrixXf two = a.transpose() * a;
  EXPECT_GT((two - one).cwiseAbs().maxCoeff(), 0.0f);
  PinEigenBlocking();
  EXPECT_EQ(Eigen::nbThreads(), 1);
  const Eigen::MatrixXf two_pinned = a.transpose() * a;
  EXPECT_EQ((two_pinned - one).cwiseAbs().maxCoeff(), 0.0f);
  Eigen::setNbThreads(saved);
}

// The CLI's subcommands all start from MakeContext: it pins the sizes and
// Eigen's thread count, whatever --threads says.
TEST(EigenBlocking, EverySubcommandsContextPinsTheSizes) {
  Eigen::setCpuCacheSizes(64 << 10, 1 << 20, 256 << 20);
  Eigen::setNbThreads(2);
  CommonOptions options;
  options.threads = 2;
  options.quiet = true;
  MakeContext(options);
  EXPECT_EQ(Eigen::l1CacheSize(), kPinnedL1Cache);
  EXPECT_EQ(Eigen::l2CacheSize(), kPinnedL2Cache);
  EXPECT_EQ(Eigen::l3CacheSize(), kPinnedL3Cache);
  EXPECT_EQ(Eigen::nbThreads(), 1);
}

}  // namespace
}  // namespace shadowsg
