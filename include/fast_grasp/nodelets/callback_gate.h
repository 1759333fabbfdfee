// Keeps a nodelet's callbacks out of its destructor. Shutting a ros::Subscriber down waits for its
// running callback only while roscpp is up: once ros::shutdown() has run (SIGINT, the end of every
// rostest) Subscriber::shutdown() returns at once, while the manager's worker threads still finish
// the callbacks they had picked up when the nodelets are deleted. ThreadSanitizer saw ArmPlanner's
// jointCallback write a member that ~ArmPlannerNodelet was destroying (docs/tests.md).
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
