// A short timeline of time-stamped target poses (a controller's pose stream) and the reference
// pose it gives at any time: the poses interpolated at that time minus a small delay (linear in
// position, slerp in rotation), so that the reference moves along the commanded path at the
// commanded pace whatever the rate and the jitter with which the poses arrive. Without the delay
// the reference would run past the newest pose and stop until the next one arrives.
//
// The delay is the longest recent time from a pose's stamp until the next pose arrived (one
// message interval plus the lateness with which poses reach the simulation), bounded by
// kMaxDelay; it grows at once and shrinks slowly (a loaded machine's hiccups recur), and every
// change of it is spread over time (the reference time runs at 1 -/+ kWarp of the time) so that the
// reference never jumps. When the stream stops, the reference holds the last pose; when it resumes,
// the reference starts from there (after more than kMaxDelay without a pose, as a new stream). All
// times are the simulation's (s). Fixed capacity: nothing allocates.
#pragma once

#include <Eigen/Geometry>
#include <array>

namespace corde {

class PoseTimeline {
 public:
  static constexpr int kCapacity = 128;     // poses kept (thinned out when it is full)
  static constexpr double kMaxDelay = 0.3;  // s
  // A new stream starts this long behind its first stamp, gliding from the reference it takes
  // over to the first pose.
  static constexpr double kFirstDelay = 0.05;   // s
  static constexpr double kDelayMargin = 5e-3;  // s beyond the longest gap
  static constexpr double kDelayDecay = 5e-3;   // s of delay per s: how fast it shrinks
  static constexpr double kWarp = 0.1;          // the reference time's rate stays within 1 -/+ it

  struct Sample {
    double time = 0.0;
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  };

  bool empty() const { return size_ == 0; }
  int size() const { return size_; }
  void clear() { size_ = head_ = 0; }

  // The pose `p`, `q` (unit) for time `stamp`, received at time `now`. A new stream (empty
  // timeline) starts from the reference (p_now, q_now) it takes over at `now`. A stamp not later
  // than the newest one's, or not finite, is ignored (returns false): the timeline stays in time
  // order and a duplicate changes nothing.
  bool add(double now, double stamp, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
           const Eigen::Vector3d& p_now, const Eigen::Quaterniond& q_now);

  // The reference at time t (the timeline must not be empty).
  void at(double t, Eigen::Vector3d* p, Eigen::Quaterniond* q) const;
  // The time at which the poses are interpolated at time t, t - delay(t) (increasing with t).
  double reference_time(double t) const { return t - delay(t); }
  double delay(double t) const;
  // True once the reference holds the newest pose (from time t on, if nothing is added).
  bool ended(double t) const { return size_ == 0 || reference_time(t) >= newest().time; }
  const Sample& newest() const { return get(size_ - 1); }
  const Sample& get(int i) const { return buf_[(head_ + i) % kCapacity]; }

 private:
  void push(const Sample& s);
  Sample& slot(int i) { return buf_[(head_ + i) % kCapacity]; }
  void start(double now, double delay);
  void change_delay(double now, double from, double to);

  std::array<Sample, kCapacity> buf_;
  int head_ = 0, size_ = 0;
  double longest_gap_ = 0.0;   // decaying maximum of (arrival - previous stamp)
  double last_arrival_ = 0.0;  // `now` of the newest add
  // delay(t): from d_from_ at t_change_ to d_to_ at rate kWarp, then d_to_.
  double d_from_ = 0.0, d_to_ = 0.0, t_change_ = 0.0, t_changed_ = 0.0;
};

}  // namespace corde
