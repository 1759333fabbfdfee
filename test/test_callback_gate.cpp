// CallbackGate (nodelets/callback_gate.h), the process-exit fix of docs/tests.md's TSan table:
// after ros::shutdown() a subscriber's shutdown no longer waits for its running callback, so a
// nodelet's destructor closes its gate first. What the destructor relies on is checked here with
// plain threads: close() returns only after every callback inside has left, and a callback that
// arrives after close() is turned away. (test_nodelet_unload checks the manager's side: it never
// deletes a nodelet under a callback from the nodelet's own queues.)
#include "fast_grasp/nodelets/callback_gate.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

namespace
{
using fast_grasp::CallbackGate;

/// A one-way latch (std::latch is C++20).
class Signal
{
public:
  void set()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    set_ = true;
    changed_.notify_all();
  }
  bool waitFor(std::chrono::milliseconds timeout)
  {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return set_; });
  }

private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool set_ = false;
};
}  // namespace

TEST(CallbackGate, AnOpenGateLetsEveryCallbackIn)
{
  CallbackGate gate;
  const CallbackGate::Pass first = gate.enter();
  const CallbackGate::Pass second = gate.enter();  // callbacks of one nodelet run side by side
  EXPECT_TRUE(first);
  EXPECT_TRUE(second);
}

TEST(CallbackGate, CloseWaitsForTheCallbackInsideAndTurnsLaterOnesAway)
{
  CallbackGate gate;
  Signal inside;
  Signal may_leave;
  std::atomic<bool> callback_left{ false };
  std::thread callback([&] {
    const CallbackGate::Pass pass = gate.enter();
    ASSERT_TRUE(pass);
    inside.set();
    may_leave.waitFor(std::chrono::seconds(30));
    callback_left = true;  // the last write the destructor must not overtake
  });
  ASSERT_TRUE(inside.waitFor(std::chrono::seconds(30)));

  std::atomic<bool> closed{ false };
  std::thread destructor([&] {
    gate.close();
    closed = true;
    // Whatever the callback wrote before it left is visible once close() returned.
    EXPECT_TRUE(callback_left);
  });
  // close() must still be waiting while the callback is inside (a wrong gate fails here at
  // once; a right one cannot be caught out by a slow machine).
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(closed) << "close() returned while a callback was inside";
  may_leave.set();
  callback.join();
  destructor.join();
  EXPECT_TRUE(closed);

  const CallbackGate::Pass late = gate.enter();
  EXPECT_FALSE(late) << "a callback after close() must return at once";
}

TEST(CallbackGate, ManyCallbacksNeverRunAfterClose)
{
  CallbackGate gate;
  std::atomic<bool> gate_closed{ false };
  std::atomic<int> ran_after_close{ 0 };
  std::atomic<int> turned_away{ 0 };
  std::atomic<int> ran{ 0 };
  std::vector<std::thread> workers;
  for (int w = 0; w < 4; ++w)
    workers.emplace_back([&] {
      for (;;)  // callbacks keep coming until the gate turns this worker away
      {
        const CallbackGate::Pass pass = gate.enter();
        if (!pass)
        {
          ++turned_away;
          return;
        }
        if (gate_closed)
          ++ran_after_close;
        ++ran;
      }
    });
  while (ran < 1000)
    std::this_thread::yield();
  gate.close();
  gate_closed = true;  // set after close() returned: no pass may be open any more
  for (std::thread& worker : workers)
    worker.join();
  EXPECT_EQ(ran_after_close, 0);
  EXPECT_EQ(turned_away, 4);
}
