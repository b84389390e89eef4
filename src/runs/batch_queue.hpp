// The hand-over of records between two threads of the io layer (a parser
// thread and the pipeline, the pipeline and a writer thread): a ring of a
// few preallocated batches, filled by one producer and drained in order by
// one consumer. A batch changes hands under the mutex; its records are
// written and read outside it by the side that owns it, so no record is
// ever shared. No allocation after construction: a batch keeps its
// capacity from one use to the next.
//
// Errors: the producer closes the stream with its exception (a parse error),
// which the consumer gets after the batches before it (in order); a failing
// consumer stops the ring with its exception (a write error), which the
// producer gets at its next acquire(). Either side abandons the ring with
// stop() (an exception of its own): the other side then sees the end.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <vector>

namespace moa::io {

template <class T>
class BatchQueue {
 public:
  /// `batches` batches of `capacity` records each (both at least 1).
  BatchQueue(std::size_t batches, std::size_t capacity) : ring_(batches) {
    for (auto& batch : ring_) batch.reserve(capacity);
  }
  BatchQueue(const BatchQueue&) = delete;
  BatchQueue& operator=(const BatchQueue&) = delete;

  std::size_t capacity() const { return ring_.front().capacity(); }

  // --- producer

  /// An empty batch to fill, once the consumer has released one; nullptr if
  /// the ring was stopped; rethrows the consumer's exception if it failed.
  std::vector<T>* acquire() {
    std::unique_lock lock(mutex_);
    space_.wait(lock, [&] { return stopped_ || submitted_ - released_ < ring_.size(); });
    if (stopped_) {
      if (error_) std::rethrow_exception(error_);
      return nullptr;
    }
    std::vector<T>& batch = ring_[submitted_ % ring_.size()];
    batch.clear();
    return &batch;
  }
  /// Hands the batch of the last acquire() over to the consumer.
  void submit() {
    {
      const std::lock_guard lock(mutex_);
      ++submitted_;
    }
    data_.notify_one();
  }
  /// No more batches; `error`, if any, reaches the consumer after them.
  void close(std::exception_ptr error = nullptr) {
    {
      const std::lock_guard lock(mutex_);
      closed_ = true;
      error_ = std::move(error);
    }
    data_.notify_one();
  }

  // --- consumer

  /// The next full batch, in order; nullptr at the end of the stream or if
  /// the ring was stopped; rethrows the producer's close() error at the end.
  const std::vector<T>* next() {
    std::unique_lock lock(mutex_);
    data_.wait(lock, [&] { return stopped_ || closed_ || submitted_ > released_; });
    if (stopped_) return nullptr;
    if (submitted_ > released_) return &ring_[released_ % ring_.size()];
    if (error_) std::rethrow_exception(error_);
    return nullptr;
  }
  /// Gives the batch of the last next() back to the producer.
  void release() {
    {
      const std::lock_guard lock(mutex_);
      ++released_;
    }
    space_.notify_one();
  }

  // --- either side

  /// Abandons the ring: both sides see the end. `error` (a consumer's
  /// failure) is rethrown to the producer.
  void stop(std::exception_ptr error = nullptr) {
    {
      const std::lock_guard lock(mutex_);
      stopped_ = true;
      if (error) error_ = std::move(error);
    }
    space_.notify_all();
    data_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable space_;  ///< the producer waits for a released batch
  std::condition_variable data_;   ///< the consumer waits for a submitted batch
  std::vector<std::vector<T>> ring_;
  std::size_t submitted_ = 0;  ///< batches handed over so far
  std::size_t released_ = 0;   ///< batches given back so far (<= submitted_)
  bool closed_ = false;
  bool stopped_ = false;
  std::exception_ptr error_;
};

}  // namespace moa::io
