// corde_sim_node's one way in: every input (topic messages, tf-driven goals, service requests,
// dynamic_reconfigure updates) becomes a command in this queue, and only the loop thread applies
// commands, between batches of steps, oldest first. No ROS here.
//
// Threading model of corde_sim_node (the one place it is stated; docs/ros_interface.md#threading):
// - The loop thread (main) owns the simulation: the world, its guard and grasps, the outputs. It
//   serves the global callback queue (topic callbacks, tf input, publisher connections,
//   diagnostics) between batches of steps, polls tf for followed frames, drains this queue, steps,
//   and publishes what is due. Nothing else touches the simulation.
// - Service threads (NodeServices on their own callback queue and spinner) turn each request
//   into a command and wait until the loop has applied it; the work that needs no simulation
//   state (reading a scene file, its statics and automatic choices, a trial step of a candidate
//   world) runs there, so that the loop keeps its output rates meanwhile.
// - dynamic_reconfigure runs on its own queue and thread (its server writes every parameter to
//   the master); its callback checks the values, queues them and waits like a service.
// A callback never blocks the loop: the loop only takes commands and sets replies.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <utility>

#include "corde_sim/ros/input_events.h"

namespace corde_sim {

// What a caller waits for: set once by the loop when its command is applied (at once, or later:
// a ~step answers once its steps are run), or when the queue closes.
class Reply {
 public:
  void set() {
    std::lock_guard<std::mutex> lock(m_);
    done_ = true;
    cv_.notify_all();
  }
  void wait() {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [this] { return done_; });
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  bool done_ = false;
};
using ReplyPtr = std::shared_ptr<Reply>;

class CommandQueue {
 public:
  // Applied in the loop thread; `reply` is null for a command nobody waits for. The apply
  // function sets the reply when the command's effect is complete (it may keep it to set later).
  using Apply = std::function<void(const ReplyPtr& reply)>;
  struct Command {
    double stamp = 0.0;  // steady wall clock (s) at arrival: the queue's order
    bool is_input = false;
    InputEvent input;  // is_input: a topic or tf input for a grasp
    Apply apply;       // otherwise
    ReplyPtr reply;
  };

  // A grasp input. An input of the same kind for the same grasp still waiting is replaced (a
  // pose or frame only by a newer one) and the new one goes to the back: the queue holds at most
  // one input per grasp and kind, however many arrive while the loop is busy or paused.
  void push_input(InputEvent e) {
    std::lock_guard<std::mutex> lock(m_);
    if (closed_) return;
    for (auto it = q_.begin(); it != q_.end(); ++it) {
      if (!it->is_input || it->input.kind != e.kind || it->input.grasp != e.grasp) continue;
      const bool pose = e.kind == InputEvent::Kind::kPose || e.kind == InputEvent::Kind::kFrame;
      if (pose && e.input_time < it->input.input_time) return;
      q_.erase(it);
      --inputs_;
      break;
    }
    Command c;
    c.stamp = now();
    c.is_input = true;
    c.input = std::move(e);
    q_.push_back(std::move(c));
    ++inputs_;
  }

  // Called (outside the lock) after a command other than an input is queued: wakes the loop.
  void set_wake(std::function<void()> wake) { wake_ = std::move(wake); }

  // Queues `apply` and returns at once (for the loop thread itself, and before the loop runs).
  void post(Apply apply) {
    {
      std::lock_guard<std::mutex> lock(m_);
      if (closed_) return;
      push_locked(std::move(apply), nullptr);
    }
    if (wake_) wake_();
  }

  // Queues `apply` and blocks until the loop has applied it and set the reply. Returns false,
  // without `apply` having run, if the queue is or gets closed first (the node shuts down). Never
  // call it from the loop thread.
  bool call(Apply apply) {
    auto reply = std::make_shared<Reply>();
    auto applied = std::make_shared<bool>(false);
    {
      std::lock_guard<std::mutex> lock(m_);
      if (closed_) return false;
      push_locked(
          [apply = std::move(apply), applied](const ReplyPtr& r) {
            *applied = true;
            apply(r);
          },
          reply);
    }
    if (wake_) wake_();
    reply->wait();
    return *applied;  // (set in the loop before the reply: ordered by the reply's mutex)
  }

  // Every command waiting, oldest first; the queue is left empty.
  std::deque<Command> take() {
    std::lock_guard<std::mutex> lock(m_);
    std::deque<Command> out;
    out.swap(q_);
    inputs_ = 0;
    return out;
  }

  // Grasp inputs waiting (diagnostics).
  size_t inputs() const {
    std::lock_guard<std::mutex> lock(m_);
    return inputs_;
  }

  // No command is taken from now on: callers waiting for a command still queued return false.
  // (Replies the loop kept must be set by the loop.)
  void close() {
    std::deque<Command> dropped;
    {
      std::lock_guard<std::mutex> lock(m_);
      closed_ = true;
      dropped.swap(q_);
      inputs_ = 0;
    }
    for (Command& c : dropped)
      if (c.reply) c.reply->set();
  }

 private:
  static double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  void push_locked(Apply apply, ReplyPtr reply) {
    Command c;
    c.stamp = now();
    c.apply = std::move(apply);
    c.reply = std::move(reply);
    q_.push_back(std::move(c));
  }

  std::function<void()> wake_;  // set before any other thread queues
  mutable std::mutex m_;
  std::deque<Command> q_;
  size_t inputs_ = 0;
  bool closed_ = false;
};

}  // namespace corde_sim
