#pragma once
/// What an activation transfer's generic payload carries. Its data are the simulator's values
/// of the rows it moves (floats: data length = values x 4, address = the byte offset of the
/// first value in the image's activation), so address, data pointer and length are true; the
/// bytes it puts on the wire, the values at the platform's precision
/// (platform.activation_bytes), come as a `WireBytes` extension, which the interconnects
/// (Bus, MeshNoc) time and count. A payload without one moves its data length.
#include <tlm>

namespace xbarsim {

struct WireBytes : tlm::tlm_extension<WireBytes> {
  explicit WireBytes(long long b = 0) : bytes(b) {}
  long long bytes;
  tlm::tlm_extension_base* clone() const override { return new WireBytes(*this); }
  void copy_from(const tlm::tlm_extension_base& other) override { *this = static_cast<const WireBytes&>(other); }
};

/// The bytes a transfer puts on the wire.
inline long long wire_bytes(const tlm::tlm_generic_payload& p) {
  const WireBytes* w = p.get_extension<WireBytes>();
  return w ? w->bytes : static_cast<long long>(p.get_data_length());
}

}  // namespace xbarsim
