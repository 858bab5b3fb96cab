// libFuzzer harness: read_csv_matrix on arbitrary file contents.
// Expected outcome for bad input: xbarsim::InputError. Anything else is a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_util.h"
#include "sw/common/csv.h"
#include "sw/common/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = xbarsim_fuzz::temp_path("csv");
  xbarsim_fuzz::write_file(path, data, size);
  try {
    const Eigen::MatrixXd m = xbarsim::read_csv_matrix(path);
    // The documented contract: a non-empty rectangular table of finite numbers.
    XBARSIM_FUZZ_CHECK(m.rows() >= 1 && m.cols() >= 1 && m.allFinite());
  } catch (const xbarsim::InputError&) {
  }
  return 0;
}
