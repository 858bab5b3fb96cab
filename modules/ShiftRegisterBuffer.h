#pragma once
/// Input shift register of a tile (dense mapping): holds the unrolled convolution window in
/// the dense-mapping order r = (kx*k_h + ky)*c_in + c and, as the window moves right by the
/// stride, shifts out the oldest window columns and shifts in only the new ones
/// (stride*k_h*c_in entries); a new output row (or a stride wider than the kernel) refills
/// the whole window. Counts the entries shifted in and the refills.
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/simple_target_socket.h>

#include "modules/LayerJob.h"
#include "modules/TileUnit.h"
#include "modules/sim_time.h"

namespace xbarsim {

class ShiftRegisterBuffer : public TileUnit {
 public:
  tlm_utils::simple_target_socket<ShiftRegisterBuffer> ctrl2sr{"ctrl2sr"};
  tlm_utils::simple_initiator_socket<ShiftRegisterBuffer> sr2dac{"sr2dac"};

  ShiftRegisterBuffer(sc_core::sc_module_name name, double clock_ns, int entries_per_cycle)
      : TileUnit(name, kShift), clock_ns_(clock_ns), entries_per_cycle_(entries_per_cycle) {
    ctrl2sr.register_b_transport(this, &ShiftRegisterBuffer::b_transport);
  }

  long long shifted_entries() const { return shifted_; }
  long long refills() const { return refills_; }

  /// Fills job.xq with the register contents of every iteration of the pass (pure function, no
  /// timing); timing only: counts the entries of the transaction's iterations.
  static void fill(LayerJob& job) {
    const LinearLayer& L = *job.layer;
    const int K = L.rows(), n = job.iterations(), col = L.k_h * L.c_in;
    const int H = L.in.h, W = L.in.w;
    job.stage_ns[kShift].assign(static_cast<size_t>(job.group_iterations()), 0.0);
    if (job.timing_only) {  // the entries each iteration of the transaction shifts in, as below
      for (int k = 0; k < job.group_iterations(); ++k) {
        const int it = job.first_iteration + k;
        const bool reload = it % L.out.w == 0 || L.stride_w >= L.k_w;
        const int shifted = reload ? K : L.stride_w * col;
        job.refills += reload;
        job.shifted_entries += shifted;
        job.stage_ns[kShift][static_cast<size_t>(k)] = shifted;
      }
      return;
    }
    job.xq.resize(n, K);  // row it: the register's contents at iteration it
    auto load_column = [&](float* dst, int oy, int x) {
      for (int ky = 0; ky < L.k_h; ++ky) {
        const int y = oy * L.stride_h - L.pad_t + ky;
        const bool inside = y >= 0 && y < H && x >= 0 && x < W;
        for (int c = 0; c < L.c_in; ++c)
          dst[ky * L.c_in + c] = inside ? job.activation[(static_cast<size_t>(c) * H + y) * W + x] : 0.0f;
      }
    };
    for (int oy = 0; oy < L.out.h; ++oy)
      for (int ox = 0; ox < L.out.w; ++ox) {
        int shifted;
        const int it = oy * L.out.w + ox;
        float* reg = job.xq.row(it).data();
        if (ox == 0 || L.stride_w >= L.k_w) {  // (re)load the whole window
          for (int kx = 0; kx < L.k_w; ++kx) load_column(reg + kx * col, oy, kx - L.pad_l + ox * L.stride_w);
          shifted = K;
          ++job.refills;
        } else {  // shift by the stride: drop the oldest columns, append the new ones
          const int s = L.stride_w;
          const float* prev = job.xq.row(it - 1).data();
          std::copy(prev + s * col, prev + K, reg);
          for (int q = 0; q < s; ++q) {
            const int kx = L.k_w - s + q;
            load_column(reg + kx * col, oy, ox * L.stride_w - L.pad_l + kx);
          }
          shifted = s * col;
        }
        job.shifted_entries += shifted;
        job.stage_ns[kShift][it] = shifted;  // entries; converted to time by the module
      }
  }

 private:
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    LayerJob* job = job_of(p);
    if (!job) {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    const long long before_s = job->shifted_entries, before_r = job->refills;
    fill(*job);
    for (double& t : job->stage_ns[kShift]) t = std::ceil(t / entries_per_cycle_) * clock_ns_;
    shifted_ += job->shifted_entries - before_s;
    refills_ += job->refills - before_r;
    sr2dac->b_transport(p, delay);
  }

  double clock_ns_;
  int entries_per_cycle_;
  long long shifted_ = 0, refills_ = 0;
};

}  // namespace xbarsim
