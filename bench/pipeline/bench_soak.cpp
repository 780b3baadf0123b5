// The 100,000-frame soak (issue 19): mixed simulated, noisy and adversarial frames through the
// threaded Runner with the default configuration, figures every 10,000 frames, checks at the
// end. A plain executable (prints a table, exits 1 when a check fails), not a Google Benchmark.
//
//   bench_soak [--frames=100000] [--checkpoint=10000] [--seed=1] [--bound-ms=X] [--wall]
//
// Frame times are the pipeline's own timer, reading the worker thread's CPU clock (a loaded
// host preempts the worker; --wall uses the monotonic clock the pipeline uses in production).
// The worst frame is checked against --bound-ms, by default the documented bound for the
// default configuration (docs/reliability.md, "Worst-case frames").
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "dynamap/platform/clock.hpp"
#include "soak.hpp"

namespace {

using namespace dynamap;

/// The documented worst-frame bound of the default configuration on the reference host
/// (docs/reliability.md, "Worst-case frames"; bench_worst_case measures it).
constexpr double kDefaultBoundMs = 33.3;

std::uint64_t cpu_clock() {
  return platform::thread_cpu_ns();
}
std::uint64_t wall_clock() {
  return platform::monotonic_ns();
}

double mib(std::uint64_t b) {
  return static_cast<double>(b) / (1024.0 * 1024.0);
}
double ms(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-6;
}

bool arg(const char* a, const char* name, std::string& value) {
  const std::size_t n = std::strlen(name);
  if (std::strncmp(a, name, n) != 0 || a[n] != '=') return false;
  value = a + n + 1;
  return true;
}

struct Options {
  std::uint64_t frames = 100'000, checkpoint = 10'000, seed = 1;
  double bound_ms = kDefaultBoundMs;
  bool wall = false;
};

/// Reads the command line into `opt`; on a bad argument or too few checkpoints prints why and
/// returns false.
bool parse_args(int argc, char** argv, Options& opt) {
  for (int i = 1; i < argc; ++i) {
    std::string v;
    if (arg(argv[i], "--frames", v)) {
      opt.frames = std::strtoull(v.c_str(), nullptr, 10);
    } else if (arg(argv[i], "--checkpoint", v)) {
      opt.checkpoint = std::strtoull(v.c_str(), nullptr, 10);
    } else if (arg(argv[i], "--seed", v)) {
      opt.seed = std::strtoull(v.c_str(), nullptr, 10);
    } else if (arg(argv[i], "--bound-ms", v)) {
      opt.bound_ms = std::strtod(v.c_str(), nullptr);
    } else if (std::strcmp(argv[i], "--wall") == 0) {
      opt.wall = true;
    } else {
      std::fprintf(stderr,
                   "usage: %s [--frames=N] [--checkpoint=N] [--seed=N] [--bound-ms=X] "
                   "[--wall]\n",
                   argv[0]);
      return false;
    }
  }
  if (opt.checkpoint == 0 || opt.frames < 2 * opt.checkpoint) {
    std::fprintf(stderr, "need at least two checkpoints (the first is the warm-up)\n");
    return false;
  }
  return true;
}

/// Prints one checkpoint's table row and its refused-by-kind line.
void print_checkpoint(const test::SoakCheckpoint& c) {
  const RunnerCounters& r = c.runner;
  std::printf("| %" PRIu64 " | %.2f | %.2f | %.2f | %.2f | %" PRIu64 " | %" PRIu64 " | %" PRIu64
              " | %" PRIu64 " | %" PRIu64 " | %" PRIu64 " | %" PRIu64 " | %" PRIu64 " | %" PRIu64
              " | %" PRIu64 " | %" PRIu64 " | %" PRIu64 " | %" PRIu64 " |\n",
              c.frames, mib(c.rss_bytes), ms(c.worst_frame_ns), ms(c.p999_frame_ns),
              ms(c.median_frame_ns), c.over_budget, r.submitted, r.processed, r.failed,
              r.rejected_full, r.rejected_bad, r.rejected_stopped, r.dropped_at_stop,
              c.pipeline.rays_dropped, c.pipeline.blocks_evicted, c.pipeline.detections_dropped,
              c.pipeline.tracks_refused, c.snapshots_seen);
  std::printf("  refused by kind:");
  for (std::size_t i = 0; i < test::kSoakKinds; ++i) {
    const auto k = static_cast<test::SoakKind>(i);
    if (test::pipeline_refuses(k) || test::submit_refuses(k)) {
      std::printf(" %s %" PRIu64, test::to_string(k), c.sent[i]);
    }
  }
  std::printf("\n");
  std::fflush(stdout);
}

/// Runs the soak, printing the table as checkpoints arrive, into `cps`; false when the runner
/// did not start or did not drain (or the pipeline did not initialise).
bool run(const Options& opt, std::vector<test::SoakCheckpoint>& cps) {
  auto pipeline = std::make_unique<Pipeline>();
  PipelineConfig config;  // defaults: the 640x480 camera
  // The bound as the whole-frame budget: the pipeline counts the frames over it (the adaptive
  // stride stays off, so the budget changes nothing else).
  config.budgets.frame_ns = static_cast<std::uint64_t>(opt.bound_ms * 1e6);
  if (!ok(pipeline->init(config))) return false;
  pipeline->set_clock(opt.wall ? &wall_clock : &cpu_clock);

  std::printf("soak: %" PRIu64 " frames, seed %" PRIu64 ", default configuration, %s time\n",
              opt.frames, opt.seed, opt.wall ? "wall" : "worker CPU");
  std::printf(
      "| frames | RSS MiB | worst ms | p99.9 ms | median ms | over bound | submitted | processed | "
      "failed | "
      "full (retried) | bad | stopped | dropped | rays dropped | blocks evicted | "
      "detections dropped | tracks refused | snapshots |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  const std::uint64_t t0 = platform::monotonic_ns();
  const bool ran = test::run_soak(*pipeline, opt.frames, opt.checkpoint, opt.seed,
                                  [&](const test::SoakCheckpoint& c) {
                                    print_checkpoint(c);
                                    cps.push_back(c);
                                  });
  const double seconds = static_cast<double>(platform::monotonic_ns() - t0) * 1e-9;
  if (!ran) {
    std::printf("FAIL: the runner did not start or did not drain\n");
    return false;
  }
  const test::SoakCheckpoint& last = cps.back();
  std::printf("\nframes by kind:");
  for (std::size_t i = 0; i < test::kSoakKinds; ++i) {
    std::printf(" %s %" PRIu64, test::to_string(static_cast<test::SoakKind>(i)), last.sent[i]);
  }
  std::printf("\nwall time %.0f s\n", seconds);
  return true;
}

/// Checks the checkpoints (counters add up, RSS flat after the warm-up, worst frame within the
/// bound), prints the verdict and returns the number of failed checks.
int report(const Options& opt, const std::vector<test::SoakCheckpoint>& cps) {
  int failures = 0;
  for (const auto& c : cps) {
    const char* problem = test::soak_counter_problem(c);
    if (*problem != '\0') {
      std::printf("FAIL at %" PRIu64 " frames: %s\n", c.frames, problem);
      ++failures;
    }
  }
  // RSS after the warm-up (the first checkpoint) stays within +-1 % of its value there.
  const double warm = static_cast<double>(cps.front().rss_bytes);
  double worst_dev = 0;
  for (std::size_t i = 1; i < cps.size(); ++i) {
    const double dev = (static_cast<double>(cps[i].rss_bytes) - warm) / warm;
    if (std::abs(dev) > std::abs(worst_dev)) worst_dev = dev;
  }
  std::printf("RSS after warm-up: %.2f MiB, largest change %+.3f %% (limit +-1 %%)\n",
              mib(cps.front().rss_bytes), 100.0 * worst_dev);
  if (std::abs(worst_dev) > 0.01) ++failures;
  std::uint64_t worst = 0, over = 0, p999 = 0;
  for (const auto& c : cps) {
    worst = std::max(worst, c.worst_frame_ns);
    p999 = std::max(p999, c.p999_frame_ns);
    over += c.over_budget;
  }
  std::printf("worst frame %.2f ms, largest p99.9 %.2f ms, %" PRIu64 " of %" PRIu64
              " processed frames over the bound of %.1f ms\n",
              ms(worst), ms(p999), over, cps.back().runner.processed, opt.bound_ms);
  if (ms(worst) > opt.bound_ms) {
    std::printf("FAIL: worst frame over the bound\n");
    ++failures;
  }
  std::printf("%s\n", failures == 0 ? "PASS" : "FAIL");
  return failures;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse_args(argc, argv, opt)) return 2;
  std::vector<test::SoakCheckpoint> cps;
  if (!run(opt, cps)) return 1;
  return report(opt, cps) == 0 ? 0 : 1;
}
