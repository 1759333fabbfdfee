// Keeps a nodelet's callbacks out of its destructor in a way ThreadSanitizer can see. Nodelet's
// manager already destroys a nodelet only after every callback from its queues has returned (it
// holds a reference to the nodelet around each call: test_nodelet_unload's NodeletLifetime tests),
// but it counts that reference inside Debian's uninstrumented libnodeletlib, so TSan reported
// ~ArmPlannerNodelet against jointCallback at the end of every rostest (after ros::shutdown(),
// when a subscriber's shutdown no longer waits for its running callback). A gate made of a mutex
// TSan knows orders the two for it, keeps its reports for real races (docs/tests.md), and would
// also protect a callback that does not come from the nodelet's own queues.
#pragma once

#include <mutex>
#include <shared_mutex>

namespace fast_grasp
{
class CallbackGate
{
public:
  /// Held for the whole callback; false once the destructor closed the gate: return at once.
  class Pass
  {
  public:
    explicit Pass(std::shared_mutex& mutex, const bool& closed) : lock_(mutex), open_(!closed) {}
    explicit operator bool() const { return open_; }

  private:
    std::shared_lock<std::shared_mutex> lock_;
    bool open_;
  };

  Pass enter() { return Pass(mutex_, closed_); }
  /// Waits for every callback inside, and keeps later ones out. First thing in the destructor.
  void close()
  {
    std::unique_lock<std::shared_mutex> lock(mutex_);
    closed_ = true;
  }

private:
  std::shared_mutex mutex_;
  bool closed_ = false;  // guarded by mutex_
};

}  // namespace fast_grasp
