#include "sw/nn/toeplitz.h"

#include <vector>

namespace xbarsim {

Eigen::SparseMatrix<float> toeplitz_matrix(const LinearLayer& L, bool valid) {
  const int H = L.in.h, W = L.in.w;
  const int pt = valid ? 0 : L.pad_t, pl = valid ? 0 : L.pad_l;
  const int oh = valid ? (H - L.k_h) / L.stride_h + 1 : L.out.h;
  const int ow = valid ? (W - L.k_w) / L.stride_w + 1 : L.out.w;
  std::vector<Eigen::Triplet<float>> t;
  t.reserve(static_cast<size_t>(oh) * ow * L.c_out * L.rows());
  for (int oy = 0; oy < oh; ++oy)
    for (int ox = 0; ox < ow; ++ox)
      for (int o = 0; o < L.c_out; ++o) {
        const int col = (oy * ow + ox) * L.c_out + o;
        for (int kx = 0; kx < L.k_w; ++kx)
          for (int ky = 0; ky < L.k_h; ++ky) {
            const int y = oy * L.stride_h - pt + ky, x = ox * L.stride_w - pl + kx;
            if (y < 0 || y >= H || x < 0 || x >= W) continue;
            for (int c = 0; c < L.c_in; ++c)
              t.emplace_back((c * H + y) * W + x, col, L.weight((kx * L.k_h + ky) * L.c_in + c, o));
          }
      }
  Eigen::SparseMatrix<float> m(H * W * L.c_in, oh * ow * L.c_out);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

}  // namespace xbarsim
