#pragma once
/// Numeric CSV files: one row of comma-separated numbers per line. Blank lines and lines
/// starting with '#' are skipped. Errors name the file, line and column.
#include <Eigen/Dense>
#include <string>

namespace xbarsim {

/// Reads a rectangular numeric table. Throws InputError on missing file, non-numeric
/// cell, ragged rows or an empty file.
Eigen::MatrixXd read_csv_matrix(const std::string& path);

/// Writes one row per matrix row with full double precision.
void write_csv_matrix(const std::string& path, const Eigen::MatrixXd& m);

}  // namespace xbarsim
