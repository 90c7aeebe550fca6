#pragma once
// A delay line in time: items go in with the time they are due, and come out in that order
// once the clock has passed it. It emulates a slow link inside one process (inverse_sim run
// --link-delay: the frames taken up late, the targets written late), where the kernel offers
// no delay of its own. Items pushed with a constant delay stay in order, so a FIFO is enough.

#include <cstddef>
#include <deque>
#include <limits>
#include <utility>

namespace nsim {

template <class T>
class DelayLine {
 public:
  /// Adds `item`, due at `due` (seconds, on the caller's clock; not before the last due time).
  void Push(double due, T item) { items_.emplace_back(due, std::move(item)); }

  /// Seconds from `now` to the next item's due time, at least 0; +inf when empty.
  double TimeToNext(double now) const {
    if (items_.empty()) return std::numeric_limits<double>::infinity();
    return items_.front().first > now ? items_.front().first - now : 0.0;
  }

  /// Hands every item due at `now` or before to `take`, oldest first, and removes it.
  template <class Take>
  void Release(double now, Take&& take) {
    while (!items_.empty() && items_.front().first <= now) {
      T item = std::move(items_.front().second);
      items_.pop_front();
      take(std::move(item));
    }
  }

  bool empty() const { return items_.empty(); }
  size_t size() const { return items_.size(); }

 private:
  std::deque<std::pair<double, T>> items_;
};

}  // namespace nsim
