#include "corde_sim/grasp/pose_timeline.h"

#include <algorithm>
#include <cmath>

namespace corde {

double PoseTimeline::delay(double t) const {
  if (t >= t_changed_) return d_to_;
  if (t <= t_change_) return d_from_;
  return d_from_ + (d_to_ - d_from_) * (t - t_change_) / (t_changed_ - t_change_);
}

void PoseTimeline::change_delay(double now, double from, double to) {
  d_from_ = from;
  d_to_ = to;
  t_change_ = now;
  t_changed_ = now + std::abs(to - from) / kWarp;
}

void PoseTimeline::push(const Sample& s) {
  if (size_ == kCapacity) {
    // Full of poses ahead of the reference (stamps running ahead of the simulation): every other
    // one after the first three goes, the newest stays, so the timeline spans twice the time at
    // half the resolution instead of losing the poses it is about to interpolate.
    int w = 3;
    for (int r = 4; r < size_; r += 2) slot(w++) = get(r);
    if ((size_ - 1) % 2 == 1) slot(w++) = get(size_ - 1);
    size_ = w;
  }
  Sample& out = buf_[(head_ + size_) % kCapacity];
  out = s;
  // Slerp the shorter way from the previous pose.
  if (size_ > 0 && out.q.dot(get(size_ - 1).q) < 0.0) out.q.coeffs() *= -1.0;
  ++size_;
}

bool PoseTimeline::add(double now, double stamp, const Eigen::Vector3d& p,
                       const Eigen::Quaterniond& q, const Eigen::Vector3d& p_now,
                       const Eigen::Quaterniond& q_now) {
  if (!std::isfinite(stamp) || !std::isfinite(now)) return false;
  if (size_ > 0 && !(stamp > newest().time)) return false;
  Sample s;
  s.time = stamp;
  s.p = p;
  s.q = q;
  if (size_ == 0) {
    // A new stream: from the reference taken over, held until kFirstDelay before now.
    change_delay(now, kFirstDelay, kFirstDelay);
    longest_gap_ = kFirstDelay - kDelayMargin;
    last_arrival_ = now;
    const double tau = reference_time(now);
    if (stamp > tau) {
      Sample hold;
      hold.time = tau;
      hold.p = p_now;
      hold.q = q_now;
      push(hold);
    }
    push(s);
    return true;
  }
  const Sample last = newest();
  const double gap = now - last.time;
  // A stream that stopped for longer than any delay starts again: its pause is not a gap.
  if (gap > kMaxDelay) longest_gap_ = kFirstDelay - kDelayMargin;
  longest_gap_ = std::max(gap > kMaxDelay ? 0.0 : gap,
                          longest_gap_ - kDelayDecay * std::max(0.0, now - last_arrival_));
  last_arrival_ = now;
  const double target = std::min(std::max(longest_gap_ + kDelayMargin, 0.0), kMaxDelay);
  double d_now = delay(now);
  if (reference_time(now) >= last.time) {
    // Run dry: the reference holds the newest pose, so any reference time since its stamp gives
    // the same pose. Resume from its stamp when the target delay allows, else from now on.
    d_now = std::min(std::max(target, d_now), gap);
    const double tau = now - d_now;
    if (!(stamp > tau)) {
      // Already due: the reference goes to it at once (the holder's limits shape the motion).
      clear();
      push(s);
      change_delay(now, d_now, target);
      return true;
    }
    if (tau > last.time) {
      Sample hold = last;
      hold.time = tau;
      push(hold);
    }
  }
  change_delay(now, d_now, target);
  // The poses before the reference time are not needed any more (it only increases).
  const double tau = reference_time(now);
  while (size_ >= 2 && get(1).time <= tau) {
    head_ = (head_ + 1) % kCapacity;
    --size_;
  }
  push(s);
  return true;
}

void PoseTimeline::at(double t, Eigen::Vector3d* p, Eigen::Quaterniond* q) const {
  const double tau = reference_time(t);
  const Sample& first = get(0);
  const Sample& last = newest();
  if (size_ == 1 || tau <= first.time) {
    *p = first.p;
    *q = first.q;
    return;
  }
  if (tau >= last.time) {
    *p = last.p;
    *q = last.q;
    return;
  }
  // The last sample at or before tau: get(lo).time <= tau < get(hi).time.
  int lo = 0, hi = size_ - 1;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (get(mid).time <= tau)
      lo = mid;
    else
      hi = mid;
  }
  const Sample& a = get(lo);
  const Sample& b = get(hi);
  const double f = (tau - a.time) / (b.time - a.time);
  *p = (1.0 - f) * a.p + f * b.p;
  *q = a.q.slerp(f, b.q);
}

}  // namespace corde
