#pragma once
/// The rate and the time left of a long run, for its progress bar (sw/app ProgressBar). The
/// clock starts at the first observation, not when the run was set up: whatever ran before it
/// (programming the crossbars, elaborating the platform, the pipeline's fill up to the first
/// finished image, images reused from a journal) is not counted as time spent on the items.
namespace xbarsim {

class RateMeter {
 public:
  /// `done` items were finished by time `t_s` (seconds on any steady clock).
  void observe(double t_s, int done) {
    if (!started_) {
      started_ = true;
      t0_ = t_s;
      done0_ = done;
    }
    t_ = t_s;
    done_ = done;
  }
  /// Items per second since the first observation; 0 until there is a span to measure.
  double rate() const {
    const double dt = t_ - t0_;
    return started_ && dt > 0 && done_ > done0_ ? (done_ - done0_) / dt : 0.0;
  }
  /// Seconds left until `total` at that rate; negative when there is no rate yet.
  double eta_s(int total) const {
    const double r = rate();
    return r > 0 ? (total - done_) / r : -1.0;
  }

 private:
  bool started_ = false;
  double t0_ = 0, t_ = 0;
  int done0_ = 0, done_ = 0;
};

}  // namespace xbarsim
