// A fixed-capacity FIFO queue in place (no heap): the synchroniser's pending
// epochs, the wheel rows not yet consumed, the EKF's prediction history.
// Element k counts from the oldest (k = 0) to the newest (size() - 1).
#pragma once

#include <array>
#include <cassert>
#include <cstddef>

namespace moa {

template <class T, std::size_t N>
class FixedRing {
 public:
  static constexpr std::size_t kCapacity = N;

  std::size_t size() const { return count_; }
  bool empty() const { return count_ == 0; }
  bool full() const { return count_ == N; }

  T& operator[](std::size_t k) {
    assert(k < count_);
    return items_[(first_ + k) % N];
  }
  const T& operator[](std::size_t k) const {
    assert(k < count_);
    return items_[(first_ + k) % N];
  }
  T& front() { return (*this)[0]; }
  const T& front() const { return (*this)[0]; }
  T& back() { return (*this)[count_ - 1]; }
  const T& back() const { return (*this)[count_ - 1]; }

  /// Appends a slot and returns it (its old contents: the caller sets it).
  /// The caller checks full() first.
  T& push_back() {
    assert(count_ < N);
    ++count_;
    return back();
  }
  void push_back(const T& item) { push_back() = item; }
  void pop_front() {
    assert(count_ > 0);
    first_ = (first_ + 1) % N;
    --count_;
  }
  /// Inserts at position k (0 <= k <= size()), moving the later ones back.
  void insert(std::size_t k, const T& item) {
    assert(k <= count_ && count_ < N);
    ++count_;
    for (std::size_t j = count_ - 1; j > k; --j) (*this)[j] = (*this)[j - 1];
    (*this)[k] = item;
  }
  void clear() { first_ = count_ = 0; }

 private:
  std::array<T, N> items_{};
  std::size_t first_ = 0, count_ = 0;
};

}  // namespace moa
