// machine_flops: measures this machine's single-precision FMA throughput, so that the
// scalar-field kernel's interaction rate can be put next to what the CPU can do.
//
//   g++ -O3 -march=native -pthread bench/machine_flops.cpp -o machine_flops
//   ./machine_flops [threads=2] [seconds=0.5]
//
// Each thread runs independent FMA chains on float arrays of one cache line per vector
// register (the compiler vectorises the inner loop with -march=native: AVX2 = 8 lanes,
// AVX-512 = 16 lanes). 16 independent accumulators hide the FMA latency. One FMA = 2 flops.
// Output: one JSON line {"threads":T,"gflops":G,"gflops_1thread":G1,...}; the best of several
// rounds is reported. Each thread's flops are divided by the CPU time that thread got
// (CLOCK_THREAD_CPUTIME_ID), not by wall time: on a machine shared with other jobs a thread that
// waits for a core would otherwise show as a slower core (a benchmark run beside a CI job once read
// 7 GFLOP/s on cores that do about 230). "gflops" is then what T cores give, the per-thread rates
// summed; "wall_gflops" is what this run actually got.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <time.h>
#include <vector>

namespace {

constexpr int kLanes = 16;   // floats per accumulator (one AVX-512 register, two AVX2)
constexpr int kChains = 16;  // independent accumulators

// Returns flops performed. The volatile sink keeps the result alive.
volatile float g_sink = 0.0f;

__attribute__((noinline)) double fma_block(long iters, float seed) {
    alignas(64) float acc[kChains][kLanes];
    alignas(64) float mul[kLanes];
    alignas(64) float add[kLanes];
    for (int l = 0; l < kLanes; ++l) {
        mul[l] = 0.999999f + 1e-7f * static_cast<float>(l);
        add[l] = 1e-6f * seed;
    }
    for (int c = 0; c < kChains; ++c)
        for (int l = 0; l < kLanes; ++l) acc[c][l] = seed + static_cast<float>(c * kLanes + l);
    for (long i = 0; i < iters; ++i) {
#pragma GCC unroll 16
        for (int c = 0; c < kChains; ++c)
#pragma GCC ivdep
            for (int l = 0; l < kLanes; ++l) acc[c][l] = __builtin_fmaf(acc[c][l], mul[l], add[l]);
    }
    float s = 0.0f;
    for (int c = 0; c < kChains; ++c)
        for (int l = 0; l < kLanes; ++l) s += acc[c][l];
    g_sink = g_sink + s;
    return 2.0 * static_cast<double>(iters) * kChains * kLanes;
}

double thread_cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Rates {
    double per_cpu_second = 0.0;  // sum over threads of flops / that thread's CPU seconds
    double per_wall_second = 0.0;
};

Rates run_round(int threads, double seconds) {
    // Calibrate iterations on one thread for the requested duration.
    long iters = 1 << 16;
    for (;;) {
        auto t0 = std::chrono::steady_clock::now();
        fma_block(iters, 1.0f);
        double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (dt > seconds / 4 || iters > (1L << 40)) {
            iters = static_cast<long>(static_cast<double>(iters) * seconds / std::max(dt, 1e-9));
            break;
        }
        iters *= 4;
    }
    std::vector<std::thread> pool;
    std::vector<double> flops(threads, 0.0), cpu(threads, 0.0);
    std::atomic<int> ready{0};
    auto t0 = std::chrono::steady_clock::now();
    for (int t = 0; t < threads; ++t)
        pool.emplace_back([&, t] {
            ready.fetch_add(1);
            while (ready.load() < threads) {
            }
            const double c0 = thread_cpu_seconds();
            flops[t] = fma_block(iters, 1.0f + static_cast<float>(t));
            cpu[t] = thread_cpu_seconds() - c0;
        });
    for (auto& th : pool) th.join();
    double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    Rates r;
    for (int t = 0; t < threads; ++t) {
        r.per_cpu_second += flops[t] / std::max(cpu[t], 1e-9);
        r.per_wall_second += flops[t] / dt;
    }
    return r;
}

}  // namespace

int main(int argc, char** argv) {
    int threads = argc > 1 ? std::atoi(argv[1]) : 2;
    double seconds = argc > 2 ? std::atof(argv[2]) : 0.5;
    if (threads < 1) threads = 1;
    double best1 = 0.0, bestn = 0.0, wall = 0.0;
    for (int round = 0; round < 3; ++round) {
        best1 = std::max(best1, run_round(1, seconds).per_cpu_second);
        const Rates n = run_round(threads, seconds);
        bestn = std::max(bestn, n.per_cpu_second);
        wall = std::max(wall, n.per_wall_second);
    }
    std::printf(
        "{\"threads\": %d, \"gflops\": %.2f, \"gflops_1thread\": %.2f, \"wall_gflops\": %.2f, \"lanes\": %d, "
        "\"note\": \"single precision, FMA = 2 flops, per CPU second of each thread, best of 3 rounds\"}\n",
        threads, bestn * 1e-9, best1 * 1e-9, wall * 1e-9, kLanes);
    return 0;
}
