#pragma once
/**
 * @file parallel.hpp
 * @brief Deterministic work splitting for the sensors: a range of independent items cut into
 *        contiguous chunks, one per thread (parallelFor), or handed out in small chunks to
 *        whichever thread is free (parallelForDynamic). Each item's result depends only on the item (and
 *        per-item random streams, see random.hpp), so any thread count gives the same output.
 */
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <functional>
#include <thread>
#include <vector>

namespace avsp
{
namespace sensors
{
/// Threads to use for `requested`: 0 means one per hardware thread (at least 1).
inline unsigned resolveThreads(unsigned requested)
{
  if (requested > 0)
    return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw > 0 ? hw : 1;
}

/**
 * @brief Calls fn(begin, end) on contiguous chunks covering [0, n), in parallel.
 *
 * Chunk k of T is [k n / T, (k + 1) n / T): fixed by n and T, so the split (and anything a
 * chunk computes) is reproducible. The first exception thrown by a chunk is rethrown here
 * after all threads joined.
 * @param threads 0 = hardware concurrency; never more threads than items
 */
inline void parallelFor(std::size_t n, unsigned threads, const std::function<void(std::size_t, std::size_t)>& fn)
{
  if (n == 0)
    return;
  std::size_t t = resolveThreads(threads);
  if (t > n)
    t = n;
  if (t == 1)
  {
    fn(0, n);
    return;
  }
  std::vector<std::exception_ptr> errors(t);
  std::vector<std::thread> pool;
  pool.reserve(t - 1);
  auto run = [&](std::size_t k) {
    try
    {
      fn(k * n / t, (k + 1) * n / t);
    }
    catch (...)
    {
      errors[k] = std::current_exception();
    }
  };
  for (std::size_t k = 1; k < t; ++k)
    pool.emplace_back(run, k);
  run(0);  // the calling thread takes the first chunk
  for (auto& th : pool)
    th.join();
  for (auto& e : errors)
    if (e)
      std::rethrow_exception(e);
}

/**
 * @brief Calls fn(begin, end) on chunks of at most `grain` items covering [0, n); each thread
 *        takes the next free chunk when it finishes one.
 *
 * For items of very uneven cost (camera rows: sky above the horizon is cheap, grazing rays near
 * it dear) a fixed split leaves one thread idle while the other works. Which thread runs a chunk
 * varies from run to run, so fn must give each item a result that depends on the item alone
 * (no state carried from one item to the next across chunk boundaries); the output is then the
 * same for any thread count and any schedule. The first exception thrown by a chunk is rethrown
 * here after all threads joined (the remaining chunks are skipped).
 * @param threads 0 = hardware concurrency; never more threads than chunks
 * @param grain items per chunk, >= 1
 */
inline void parallelForDynamic(std::size_t n, unsigned threads, std::size_t grain,
                               const std::function<void(std::size_t, std::size_t)>& fn)
{
  if (n == 0)
    return;
  grain = std::max<std::size_t>(grain, 1);
  const std::size_t chunks = (n + grain - 1) / grain;
  std::size_t t = std::min<std::size_t>(resolveThreads(threads), chunks);
  if (t == 1)
  {
    fn(0, n);
    return;
  }
  std::atomic<std::size_t> next{ 0 };
  std::atomic<bool> failed{ false };
  std::vector<std::exception_ptr> errors(t);
  auto run = [&](std::size_t k) {
    try
    {
      for (;;)
      {
        const std::size_t begin = next.fetch_add(grain, std::memory_order_relaxed);
        if (begin >= n || failed.load(std::memory_order_relaxed))
          return;
        fn(begin, std::min(begin + grain, n));
      }
    }
    catch (...)
    {
      errors[k] = std::current_exception();
      failed = true;
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(t - 1);
  for (std::size_t k = 1; k < t; ++k)
    pool.emplace_back(run, k);
  run(0);
  for (auto& th : pool)
    th.join();
  for (auto& e : errors)
    if (e)
      std::rethrow_exception(e);
}

}  // namespace sensors
}  // namespace avsp
