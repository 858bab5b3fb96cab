#pragma once
/// A line buffer between two stages of the pipeline: activation rows of one value (C x W
/// values of one image row each), produced in (image, row) order by one producer and read by
/// one consumer, with a capacity in bytes and credit-based backpressure: the producer
/// reserves a row's space before sending it and stalls while the buffer is full; the
/// consumer waits for the rows its window needs and releases rows it no longer needs.
#include <algorithm>
#include <string>
#include <systemc>

namespace xbarsim {

class RowBuffer {
 public:
  RowBuffer(std::string name, long long capacity_bytes, long long row_bytes, int rows_per_image)
      : name_(std::move(name)), capacity_(capacity_bytes), row_bytes_(row_bytes), rows_(rows_per_image) {}

  const std::string& name() const { return name_; }
  long long capacity_bytes() const { return capacity_; }
  long long row_bytes() const { return row_bytes_; }
  int rows_per_image() const { return rows_; }
  long long occupancy_bytes() const { return used_; }
  long long peak_bytes() const { return peak_; }

  /// Traces the occupancy (bytes) into `sig` while `*enabled`.
  void trace_to(sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>* sig, const bool* enabled) {
    sig_ = sig;
    enabled_ = enabled;
  }

  /// Producer: waits until a row fits (the time waited is the producer's stall).
  void reserve() {
    while (used_ + row_bytes_ > capacity_) sc_core::wait(space_);
    used_ += row_bytes_;
    peak_ = std::max(peak_, used_);
    traced();
  }
  /// Producer: the reserved row (image, row) has arrived.
  void commit(int image, int row) {
    committed_ = index(image, row) + 1;
    data_.notify(sc_core::SC_ZERO_TIME);
  }
  /// Rows 0..row of `image` have arrived (row < 0: nothing needed).
  bool has(int image, int row) const { return row < 0 || committed_ > index(image, row); }
  /// Consumer: waits until rows 0..row of `image` have arrived (row < 0: nothing needed).
  void wait_for(int image, int row) {
    if (row < 0) return;
    while (committed_ <= index(image, row)) sc_core::wait(data_);
  }
  /// Consumer: frees every row before (image, row); row = rows_per_image frees the image.
  void release_before(int image, int row) {
    const long long upto = std::min(index(image, row), committed_);
    if (upto <= released_) return;
    used_ -= (upto - released_) * row_bytes_;
    released_ = upto;
    space_.notify(sc_core::SC_ZERO_TIME);
    traced();
  }

 private:
  void traced() {
    if (sig_ && *enabled_) sig_->write(static_cast<int>(std::min<long long>(used_, 1LL << 30)));
  }
  long long index(int image, int row) const { return static_cast<long long>(image) * rows_ + row; }
  std::string name_;
  long long capacity_, row_bytes_;
  int rows_;
  long long used_ = 0, peak_ = 0, committed_ = 0, released_ = 0;
  sc_core::sc_event data_, space_;
  sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>* sig_ = nullptr;
  const bool* enabled_ = nullptr;
};

}  // namespace xbarsim
