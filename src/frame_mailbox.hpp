// A one-slot mailbox between the subscriber callbacks and the worker: a frame
// still waiting when a newer one arrives is replaced (and the caller counts
// it), so latency never grows with load.
#pragma once

#include <condition_variable>
#include <mutex>
#include <utility>

namespace bdis_stereo {

template <typename Frame>
class FrameMailbox {
 public:
  /// Leaves `frame` for the worker; true when it replaced one not yet taken.
  bool post(Frame frame) {
    bool replaced = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      replaced = has_frame_;
      frame_ = std::move(frame);
      has_frame_ = true;
    }
    cv_.notify_one();
    return replaced;
  }

  /// Waits for a frame; false once stop() was called.
  bool take(Frame& frame) {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return stop_ || has_frame_; });
    if (stop_) return false;
    frame = std::move(frame_);
    frame_ = Frame();
    has_frame_ = false;
    return true;
  }

  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  Frame frame_;
  bool has_frame_ = false;
  bool stop_ = false;
};

}  // namespace bdis_stereo
