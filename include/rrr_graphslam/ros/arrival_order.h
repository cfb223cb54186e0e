#pragma once
// Scans must reach local SLAM in the order they arrived, yet each waits for its own transforms and
// they settle out of order. ArrivalOrder holds them: an item is released once it and every item
// that arrived before it settled (ready, or dropped); an item that waited longer than the bound is
// given up, so one scan whose transform never comes (an unknown frame, a stamp in the future)
// cannot hold every later one back. Plain C++ and not thread-safe: the caller locks.

#include <cstddef>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

namespace rrr_graphslam::ros_adapter {

template <class Key, class Value>
class ArrivalOrder {
 public:
  /// `key` arrived at `now_sec` and waits to settle.
  void arrived(Key key, double now_sec) { items_.push_back({key, now_sec, false, std::nullopt}); }

  /// Settles `key`: `value` is ready, or nullopt for dropped. False if `key` is not waiting (it
  /// was given up by expire(), settled before, or never arrived): the caller ignores it then.
  bool settle(Key key, std::optional<Value> value) {
    for (Item& item : items_) {
      if (item.key == key && !item.settled) {
        item.settled = true;
        item.value = std::move(value);
        return true;
      }
    }
    return false;
  }

  /// The ready values at the front, in arrival order, removed (dropped ones are skipped).
  std::vector<Value> release() {
    std::vector<Value> ready;
    while (!items_.empty() && items_.front().settled) {
      if (items_.front().value) ready.push_back(std::move(*items_.front().value));
      items_.pop_front();
    }
    return ready;
  }

  /// Gives up every unsettled item that waited more than `timeout_sec`: removed and returned
  /// with its arrival time (the caller reports each). release() then lets what settled after
  /// them through.
  std::vector<std::pair<Key, double>> expire(double now_sec, double timeout_sec) {
    std::vector<std::pair<Key, double>> expired;
    for (auto it = items_.begin(); it != items_.end() && now_sec - it->arrival_sec > timeout_sec;) {
      if (it->settled) {
        ++it;
      } else {
        expired.emplace_back(it->key, it->arrival_sec);
        it = items_.erase(it);
      }
    }
    return expired;
  }

  /// Items not yet released (waiting for their own input or for an earlier one).
  std::size_t waiting() const { return items_.size(); }

 private:
  struct Item {
    Key key;
    double arrival_sec;
    bool settled;
    std::optional<Value> value;
  };
  std::deque<Item> items_;
};

}  // namespace rrr_graphslam::ros_adapter
