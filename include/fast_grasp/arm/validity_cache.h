// Remembers the verdicts of one deterministic state validity function, keyed on the exact bits
// of the joint values. ROS-free.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

namespace fast_grasp
{
/// A direct-mapped table of (joint values, verdict) for one validity function that depends on
/// the joint values alone (the arm planner's checker: fixed collision snapshot, fixed
/// parameters). A hit needs every joint value bit for bit equal to a state the function
/// answered before, so it returns exactly the verdict the function gave; -0.0 and 0.0, or two
/// NaN payloads, are different keys and simply miss. Why: a run of the planner benchmark
/// checks the same states again (OMPL's RRTConnect re-checks a goal-tree state in every
/// goal-tree extension; ompl::tools::Benchmark re-checks the solution path, whose states and
/// motion steps the planner interpolated the same way): ~13 % of the UR5 narrow passage's
/// checks (docs/benchmarks/arms.md, "Speed work, session 17 (2)"). A miss costs a hash and one
/// slot read (~100 instructions) against ~7 700 for a check; a store evicts whatever state
/// hashed to the same slot.
///
/// Thread-safe without a lock on lookups: a version counter (odd while a store is under way)
/// is read before and after a slot is read, and a lookup that saw a store under way or a
/// changed version misses. A store claims the table by moving the version from even to odd;
/// a store that finds it odd (another thread storing) is dropped, which only costs a later
/// miss. The table (slots x (joints + 1) words) is allocated by the first store.
class ValidityCache
{
public:
  /// Joint vectors longer than this bypass the table.
  static constexpr std::size_t kMaxJoints = 16;

  /// slots is rounded up to a power of two (at least 2).
  explicit ValidityCache(std::size_t joints, std::size_t slots = std::size_t(1) << 13)
    : joints_(joints), stride_(joints + 1)
  {
    std::size_t n = 2;
    unsigned bits = 1;
    while (n < slots)
    {
      n <<= 1;
      ++bits;
    }
    slots_ = n;
    shift_ = 64u - bits;
  }
  ValidityCache(const ValidityCache&) = delete;
  ValidityCache& operator=(const ValidityCache&) = delete;
  ~ValidityCache() { delete[] table_.load(std::memory_order_relaxed); }

  /// check(q) if q's bits are not in the table, else the verdict check gave them before.
  template <typename Check>
  bool valid(const double* q, Check&& check)
  {
    if (joints_ == 0 || joints_ > kMaxJoints)
      return check(q);
    std::uint64_t key[kMaxJoints];
    std::memcpy(key, q, joints_ * sizeof(double));
    const std::size_t first = slotOf(key) * stride_;
    int stored = lookup(key, first);
    if (stored >= 0)
    {
      hits_.fetch_add(1, std::memory_order_relaxed);
      return stored == 1;
    }
    const bool verdict = check(q);
    store(key, first, verdict);
    return verdict;
  }

  /// The verdict stored for q's bits: 1 valid, 0 invalid, -1 not in the table (then the
  /// caller checks q and remember()s the verdict). For callers that check several states
  /// together (ArmValidityChecker::firstInvalid).
  int find(const double* q)
  {
    if (joints_ == 0 || joints_ > kMaxJoints)
      return -1;
    std::uint64_t key[kMaxJoints];
    std::memcpy(key, q, joints_ * sizeof(double));
    const int stored = lookup(key, slotOf(key) * stride_);
    if (stored >= 0)
      hits_.fetch_add(1, std::memory_order_relaxed);
    return stored;
  }
  /// Stores the verdict of q, as valid() does after a miss.
  void remember(const double* q, bool verdict)
  {
    if (joints_ == 0 || joints_ > kMaxJoints)
      return;
    std::uint64_t key[kMaxJoints];
    std::memcpy(key, q, joints_ * sizeof(double));
    store(key, slotOf(key) * stride_, verdict);
  }

  /// Lookups answered from the table so far.
  std::uint64_t hits() const { return hits_.load(std::memory_order_relaxed); }

private:
  using Word = std::atomic<std::uint64_t>;
  // Tag word after the joints: 0 empty, 1 invalid, 2 valid.

  /// 1 valid, 0 invalid, -1 not in the table (or not readable now).
  int lookup(const std::uint64_t* key, std::size_t first) const
  {
    const Word* table = table_.load(std::memory_order_acquire);
    if (!table)
      return -1;
    const std::uint64_t before = version_.load(std::memory_order_acquire);
    if (before & 1u)
      return -1;
    const Word* entry = table + first;
    const std::uint64_t tag = entry[joints_].load(std::memory_order_relaxed);
    bool same = tag != 0;
    for (std::size_t j = 0; same && j < joints_; ++j)
      same = entry[j].load(std::memory_order_relaxed) == key[j];
    std::atomic_thread_fence(std::memory_order_acquire);
    if (!same || version_.load(std::memory_order_relaxed) != before)
      return -1;
    return tag == 2 ? 1 : 0;
  }

  void store(const std::uint64_t* key, std::size_t first, bool verdict)
  {
    std::uint64_t even = version_.load(std::memory_order_relaxed);
    if ((even & 1u) || !version_.compare_exchange_strong(even, even + 1, std::memory_order_acquire))
      return;  // another thread is storing: drop this one
    std::atomic_thread_fence(std::memory_order_release);
    Word* table = table_.load(std::memory_order_relaxed);
    if (!table)
    {
      table = new Word[slots_ * stride_]();
      table_.store(table, std::memory_order_release);
    }
    Word* entry = table + first;
    for (std::size_t j = 0; j < joints_; ++j)
      entry[j].store(key[j], std::memory_order_relaxed);
    entry[joints_].store(verdict ? 2u : 1u, std::memory_order_relaxed);
    version_.store(even + 2, std::memory_order_release);
  }

  std::size_t slotOf(const std::uint64_t* key) const
  {
    std::uint64_t h = 0x243F6A8885A308D3ull;
    for (std::size_t j = 0; j < joints_; ++j)
    {
      h = (h ^ key[j]) * 0x9E3779B97F4A7C15ull;
      h ^= h >> 29;
    }
    h *= 0xBF58476D1CE4E5B9ull;
    return static_cast<std::size_t>(h >> shift_);
  }

  std::size_t joints_;
  std::size_t stride_;
  std::size_t slots_ = 2;
  unsigned shift_ = 63;
  std::atomic<Word*> table_{ nullptr };
  std::atomic<std::uint64_t> version_{ 0 };
  std::atomic<std::uint64_t> hits_{ 0 };
};

}  // namespace fast_grasp
