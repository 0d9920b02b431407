// Serving inside a memory limit (server/memory_fit.h): the cgroup limit read from v1
// and v2 hierarchies (the smallest of the group and its ancestors), the still budget and
// segment cache shrunk to fit a tight limit, and a limit too small to draw refused with a
// message naming it, by the function and by `tetrascope serve`.
#include "tetrascope/server/memory_fit.h"

#include <gtest/gtest.h>

#include <fstream>

#include "cli_run.h"
#include "test_paths.h"
#include "tetrascope/server/server.h"

namespace tetrascope::testing {
namespace {

constexpr uint64_t kMiB = uint64_t{1} << 20;

void write_file(const std::filesystem::path& file, const std::string& text) {
  std::filesystem::create_directories(file.parent_path());
  std::ofstream(file) << text << "\n";
}

TEST(MemoryFit, CgroupLimitsAreReadFromV1AndV2AndTheSmallestAncestorWins) {
  const auto root = scratch_dir("memory-fit-cgroups");
  // v1: the group itself unlimited (2^63 rounded to a page), its parent at 500 MB
  write_file(root / "memory/a/b/memory.limit_in_bytes", "9223372036854771712");
  write_file(root / "memory/a/memory.limit_in_bytes", std::to_string(500 * kMiB));
  write_file(root / "memory/memory.limit_in_bytes", "9223372036854771712");
  auto v1 = server::cgroup_memory_limit("12:pids:/a/b\n4:memory:/a/b\n1:name=systemd:/a/b\n", root);
  ASSERT_TRUE(v1);
  EXPECT_EQ(v1->bytes, 500 * kMiB);
  EXPECT_NE(v1->source.find("cgroup v1"), std::string::npos) << v1->source;
  // v2: "max" is no limit; a number is
  write_file(root / "svc/memory.max", "max");
  EXPECT_FALSE(server::cgroup_memory_limit("0::/svc\n", root));
  write_file(root / "svc/job/memory.max", std::to_string(256 * kMiB));
  auto v2 = server::cgroup_memory_limit("0::/svc/job\n", root);
  ASSERT_TRUE(v2);
  EXPECT_EQ(v2->bytes, 256 * kMiB);
  // unreadable or garbled: no limit
  EXPECT_FALSE(server::cgroup_memory_limit("4:memory:/nowhere\nnot a line\n", root));
  write_file(root / "bad/memory.max", "lots");
  EXPECT_FALSE(server::cgroup_memory_limit("0::/bad\n", root));
}

TEST(MemoryFit, ATightLimitShrinksTheStillBudgetAndTheCache) {
  server::ServerOptions o;  // 2 workers by default in serve; set here
  o.render_workers = 2;
  const auto fit = server::fit_to_memory(o, {300 * kMiB, "test"});
  EXPECT_TRUE(fit.changed);
  // measured: 200K survived 300 MB, 500K was killed (bench/README.md, bench/results/serve_memory_limit-*)
  EXPECT_LT(fit.still_budget, 300000u);
  EXPECT_GE(fit.still_budget, 150000u);
  EXPECT_LE(fit.cache_bytes, 300 * kMiB / 8 + 1);
  EXPECT_NE(fit.message.find("300 MB"), std::string::npos) << fit.message;
  // more workers leave less for the still
  o.render_workers = 4;
  EXPECT_LT(server::fit_to_memory(o, {300 * kMiB, "test"}).still_budget, fit.still_budget);
}

TEST(MemoryFit, AGenerousLimitKeepsTheStillBudget) {
  server::ServerOptions o;
  o.render_workers = 2;
  const auto fit = server::fit_to_memory(o, {64ull << 30, "test"});
  EXPECT_EQ(fit.still_budget, o.still_budget);
  EXPECT_EQ(fit.cache_bytes, o.cache_bytes);
  EXPECT_FALSE(fit.changed);
  EXPECT_TRUE(fit.message.empty());
}

TEST(MemoryFit, AMemoryLimitTooSmallToDrawIsRefusedNamingIt) {
  server::ServerOptions o;
  o.render_workers = 2;
  try {
    server::fit_to_memory(o, {100 * kMiB, "cgroup v1 /sys/fs/cgroup/memory/x/memory.limit_in_bytes"});
    FAIL() << "a 100 MB limit should be refused";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("100 MB"), std::string::npos) << what;
    EXPECT_NE(what.find("memory.limit_in_bytes"), std::string::npos) << what;
    EXPECT_NE(what.find("--workers"), std::string::npos) << what;
  }
  // the same from the command line, before anything listens
  const CliResult r = run_cli("serve --data " + scratch_dir("memory-fit-serve").string() + " --port 0 --memory-mb 100", 30);
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("memory limit (100 MB, --memory-mb)"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace tetrascope::testing
