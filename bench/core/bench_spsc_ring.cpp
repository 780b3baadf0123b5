// SpscRing vs boost::lockfree::spsc_queue, in one binary.
//  - *_U64_TwoThreads: throughput of uint64 items between a producer (the benchmark thread) and a
//    consumer thread; each iteration moves kSmallBatch items through a 1024-slot queue.
//  - *_U64_SameThread: push then pop on one thread (per-operation cost without cache-line
//    transfers; least sensitive to other load on the machine).
//  - *_Frame_TwoThreads: 640x480 uint16 depth frames (600 KiB) through a 4-slot queue. The
//    producer unpacks a strided driver image into a frame; the consumer sums every pixel. Ours:
//    unpacked straight into the slot, read in place. Boost: unpacked into the sensor's own frame,
//    push() copies it in, the consumer reads in place with consume_one(). SlotApiStaged does the
//    same copies as boost through our slot API (unpack locally, one bulk memcpy into the slot).
// Both sides spin, yielding after kSpinsBeforeYield failed attempts (same policy for both).
// Two-thread cases pin the producer to CPU 0 and the consumer to CPU 1 when there are 2+ CPUs.
#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <thread>

#include <benchmark/benchmark.h>
#include <boost/lockfree/spsc_queue.hpp>

#include "dynamap/core/spsc_ring.hpp"
#include "dynamap/platform/thread.hpp"

namespace {

constexpr std::size_t kSmallCapacity = 1024;
constexpr std::uint64_t kSmallBatch = 1u << 20;
constexpr std::size_t kFrameCapacity = 4;
constexpr std::uint64_t kFrameBatch = 64;
constexpr int kSpinsBeforeYield = 64;

struct DepthFrame {
  std::uint64_t seq = 0;
  std::array<std::uint16_t, 640 * 480> pixels{};
};

template <typename TryFn>
void spin_until(TryFn&& try_once) {
  int spins = 0;
  while (!try_once()) {
    if (++spins == kSpinsBeforeYield) {
      spins = 0;
      std::this_thread::yield();
    }
  }
}

// Pins the calling thread to `cpu` if the machine has more than one CPU (best effort).
// DYNAMAP_BENCH_NO_PIN=1 leaves placement to the scheduler.
void pin_to(int cpu) {
  static const bool no_pin = std::getenv("DYNAMAP_BENCH_NO_PIN") != nullptr;
  if (!no_pin && std::thread::hardware_concurrency() > 1) {
    (void)dynamap::platform::set_cpu_affinity(cpu);
  }
}

// The camera driver's buffer: rows padded to a 1344-byte stride, as drivers often deliver them.
constexpr std::size_t kWidth = 640;
constexpr std::size_t kHeight = 480;
constexpr std::size_t kDriverStride = 672;  // in pixels
struct DriverImage {
  std::array<std::uint16_t, kDriverStride * kHeight> data{};
  std::uint64_t packed_sum = 0;  // sum of the 640x480 image area
  DriverImage() {
    for (std::size_t r = 0; r < kHeight; ++r) {
      for (std::size_t c = 0; c < kDriverStride; ++c) {
        data[r * kDriverStride + c] = static_cast<std::uint16_t>(500 + (r * 7 + c * 3) % 4000);
        if (c < kWidth) packed_sum += data[r * kDriverStride + c];
      }
    }
  }
};

// The sensor thread's work per frame: unpack the driver's strided rows into our packed frame and
// stamp it. With the slot API this writes straight into the ring.
void fill_frame(DepthFrame& f, const DriverImage& src, std::uint64_t seq) {
  f.seq = seq;
  for (std::size_t r = 0; r < kHeight; ++r) {
    std::memcpy(&f.pixels[r * kWidth], &src.data[r * kDriverStride],
                kWidth * sizeof(std::uint16_t));
  }
  f.pixels[0] = static_cast<std::uint16_t>(seq);  // so a stale frame cannot pass the check
}

// Reads the whole frame, as a consumer (the pipeline) would; returns false on a wrong frame.
bool check_frame(const DepthFrame& f, const DriverImage& src, std::uint64_t expected_seq,
                 std::uint64_t* checksum) {
  std::uint64_t sum = 0;
  for (std::uint16_t p : f.pixels) sum += p;
  *checksum += sum;
  const std::uint64_t expected =
      src.packed_sum - src.data[0] + static_cast<std::uint16_t>(expected_seq);
  return f.seq == expected_seq && f.pixels[0] == static_cast<std::uint16_t>(expected_seq) &&
         sum == expected;
}

// ---- uint64, two threads ----------------------------------------------------------------------

void BM_Ours_U64_TwoThreads(benchmark::State& state) {
  pin_to(0);
  auto ring = std::make_unique<dynamap::SpscRing<std::uint64_t, kSmallCapacity>>();
  bool ok = true;
  for (auto _ : state) {
    std::uint64_t bad = 0;
    std::thread consumer([&] {
      pin_to(1);
      for (std::uint64_t i = 0; i < kSmallBatch; ++i) {
        std::uint64_t v = 0;
        spin_until([&] { return ring->try_pop(v) == dynamap::Status::kOk; });
        bad += (v != i);
      }
    });
    for (std::uint64_t i = 0; i < kSmallBatch; ++i) {
      spin_until([&] { return ring->try_push(i) == dynamap::Status::kOk; });
    }
    consumer.join();
    ok = ok && bad == 0;
  }
  if (!ok) state.SkipWithError("items out of order");
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kSmallBatch));
}

void BM_Boost_U64_TwoThreads(benchmark::State& state) {
  pin_to(0);
  auto queue = std::make_unique<
      boost::lockfree::spsc_queue<std::uint64_t, boost::lockfree::capacity<kSmallCapacity>>>();
  bool ok = true;
  for (auto _ : state) {
    std::uint64_t bad = 0;
    std::thread consumer([&] {
      pin_to(1);
      for (std::uint64_t i = 0; i < kSmallBatch; ++i) {
        std::uint64_t v = 0;
        spin_until([&] { return queue->pop(v); });
        bad += (v != i);
      }
    });
    for (std::uint64_t i = 0; i < kSmallBatch; ++i) {
      spin_until([&] { return queue->push(i); });
    }
    consumer.join();
    ok = ok && bad == 0;
  }
  if (!ok) state.SkipWithError("items out of order");
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kSmallBatch));
}

// ---- uint64, one thread -----------------------------------------------------------------------

void BM_Ours_U64_SameThread(benchmark::State& state) {
  auto ring = std::make_unique<dynamap::SpscRing<std::uint64_t, kSmallCapacity>>();
  std::uint64_t i = 0;
  for (auto _ : state) {
    (void)ring->try_push(i++);
    std::uint64_t v = 0;
    (void)ring->try_pop(v);
    benchmark::DoNotOptimize(v);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

void BM_Boost_U64_SameThread(benchmark::State& state) {
  auto queue = std::make_unique<
      boost::lockfree::spsc_queue<std::uint64_t, boost::lockfree::capacity<kSmallCapacity>>>();
  std::uint64_t i = 0;
  for (auto _ : state) {
    (void)queue->push(i++);
    std::uint64_t v = 0;
    (void)queue->pop(v);
    benchmark::DoNotOptimize(v);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

// ---- depth frames, two threads ----------------------------------------------------------------

void BM_Ours_Frame_TwoThreads_SlotApi(benchmark::State& state) {
  pin_to(0);
  auto ring = std::make_unique<dynamap::SpscRing<DepthFrame, kFrameCapacity>>();
  auto driver = std::make_unique<DriverImage>();
  bool ok = true;
  std::uint64_t checksum = 0;
  for (auto _ : state) {
    std::uint64_t bad = 0;
    std::thread consumer([&] {
      pin_to(1);
      for (std::uint64_t i = 0; i < kFrameBatch; ++i) {
        const DepthFrame* f = nullptr;
        spin_until([&] { return (f = ring->try_front()) != nullptr; });
        bad += !check_frame(*f, *driver, i, &checksum);
        ring->pop_front();
      }
    });
    for (std::uint64_t i = 0; i < kFrameBatch; ++i) {
      DepthFrame* slot = nullptr;
      spin_until([&] { return (slot = ring->try_begin_push()) != nullptr; });
      fill_frame(*slot, *driver, i);  // the sensor writes straight into the ring
      ring->commit_push();
    }
    consumer.join();
    ok = ok && bad == 0;
  }
  benchmark::DoNotOptimize(checksum);
  if (!ok) state.SkipWithError("bad frame");
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kFrameBatch));
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations() * kFrameBatch * sizeof(DepthFrame)));
}

void BM_Ours_Frame_TwoThreads_SlotApiStaged(benchmark::State& state) {
  pin_to(0);
  auto ring = std::make_unique<dynamap::SpscRing<DepthFrame, kFrameCapacity>>();
  auto driver = std::make_unique<DriverImage>();
  auto staging = std::make_unique<DepthFrame>();
  bool ok = true;
  std::uint64_t checksum = 0;
  for (auto _ : state) {
    std::uint64_t bad = 0;
    std::thread consumer([&] {
      pin_to(1);
      for (std::uint64_t i = 0; i < kFrameBatch; ++i) {
        const DepthFrame* f = nullptr;
        spin_until([&] { return (f = ring->try_front()) != nullptr; });
        bad += !check_frame(*f, *driver, i, &checksum);
        ring->pop_front();
      }
    });
    for (std::uint64_t i = 0; i < kFrameBatch; ++i) {
      DepthFrame* slot = nullptr;
      spin_until([&] { return (slot = ring->try_begin_push()) != nullptr; });
      // Same copies as boost: unpack into the sensor's own frame, then one bulk copy into the slot.
      fill_frame(*staging, *driver, i);
      std::memcpy(static_cast<void*>(slot), staging.get(), sizeof(DepthFrame));
      ring->commit_push();
    }
    consumer.join();
    ok = ok && bad == 0;
  }
  benchmark::DoNotOptimize(checksum);
  if (!ok) state.SkipWithError("bad frame");
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kFrameBatch));
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations() * kFrameBatch * sizeof(DepthFrame)));
}

void BM_Boost_Frame_TwoThreads_PushCopy(benchmark::State& state) {
  pin_to(0);
  auto queue = std::make_unique<
      boost::lockfree::spsc_queue<DepthFrame, boost::lockfree::capacity<kFrameCapacity>>>();
  auto staging = std::make_unique<DepthFrame>();  // the sensor's own buffer
  auto driver = std::make_unique<DriverImage>();
  bool ok = true;
  std::uint64_t checksum = 0;
  for (auto _ : state) {
    std::uint64_t bad = 0;
    std::thread consumer([&] {
      pin_to(1);
      for (std::uint64_t i = 0; i < kFrameBatch; ++i) {
        spin_until([&] {
          return queue->consume_one(
              [&](const DepthFrame& f) { bad += !check_frame(f, *driver, i, &checksum); });
        });
      }
    });
    for (std::uint64_t i = 0; i < kFrameBatch; ++i) {
      fill_frame(*staging, *driver, i);
      spin_until([&] { return queue->push(*staging); });  // copies 600 KiB into the queue
    }
    consumer.join();
    ok = ok && bad == 0;
  }
  benchmark::DoNotOptimize(checksum);
  if (!ok) state.SkipWithError("bad frame");
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kFrameBatch));
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations() * kFrameBatch * sizeof(DepthFrame)));
}

BENCHMARK(BM_Ours_U64_TwoThreads)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Boost_U64_TwoThreads)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Ours_U64_SameThread);
BENCHMARK(BM_Boost_U64_SameThread);
BENCHMARK(BM_Ours_Frame_TwoThreads_SlotApi)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Ours_Frame_TwoThreads_SlotApiStaged)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Boost_Frame_TwoThreads_PushCopy)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
