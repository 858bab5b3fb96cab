#pragma once
/// Numeric CSV files: one row of comma-separated numbers per line. Blank lines and lines
/// starting with '#' are skipped. Errors name the file, line and column.
#include <Eigen/Dense>
#include <string>

namespace xbarsim {

/// The longest line read (about 700 000 numbers).
constexpr size_t kMaxCsvLineBytes = size_t{16} << 20;

/// Reads a rectangular numeric table from a file this run reads as `role` (register_input).
/// Throws InputError on a missing file or a directory, a non-numeric cell (quoted in part),
/// ragged rows, a line longer than kMaxCsvLineBytes, or an empty file.
Eigen::MatrixXd read_csv_matrix(const std::string& path, const std::string& role = "the CSV input");

/// Writes one row per matrix row with full double precision.
void write_csv_matrix(const std::string& path, const Eigen::MatrixXd& m);

}  // namespace xbarsim
