#include "sw/common/csv.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <vector>

#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/common/parse.h"
#include "sw/common/output_file.h"

namespace xbarsim {

Eigen::MatrixXd read_csv_matrix(const std::string& path, const std::string& role) {
  open_as_input(path, role);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot open '" + path + "'");
  std::vector<std::vector<double>> rows;
  std::string line;
  size_t lineno = 0;
  for (LineRead r; (r = read_line(in, line, kMaxCsvLineBytes)) != LineRead::End;) {
    ++lineno;
    if (r == LineRead::TooLong)
      throw InputError(path + ":" + std::to_string(lineno) + ": a line longer than " +
                       std::to_string(kMaxCsvLineBytes >> 20) + " MiB; not a CSV file of numbers");
    if (lineno == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);  // UTF-8 byte order mark
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::vector<double> row;
    size_t pos = 0;
    size_t col = 0;
    while (true) {
      ++col;
      const auto comma = line.find(',', pos);
      std::string cell = line.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
      const auto b = cell.find_first_not_of(" \t");
      const auto e = cell.find_last_not_of(" \t");
      cell = (b == std::string::npos) ? "" : cell.substr(b, e - b + 1);
      double v = 0;
      if (!parse_finite_double(cell, v))
        throw InputError(path + ":" + std::to_string(lineno) + ": column " + std::to_string(col) + ": '" +
                         excerpt(cell) + "' is not a finite number");
      row.push_back(v);
      if (comma == std::string::npos) break;
      pos = comma + 1;
    }
    if (!rows.empty() && row.size() != rows.front().size())
      throw InputError(path + ":" + std::to_string(lineno) + ": " + std::to_string(row.size()) +
                       " values, but the first row has " + std::to_string(rows.front().size()));
    rows.push_back(std::move(row));
  }
  if (rows.empty()) throw InputError("'" + path + "' holds no data rows");
  Eigen::MatrixXd m(rows.size(), rows.front().size());
  for (size_t i = 0; i < rows.size(); ++i)
    for (size_t j = 0; j < rows[i].size(); ++j) m(i, j) = rows[i][j];
  return m;
}

void write_csv_matrix(const std::string& path, const Eigen::MatrixXd& m) {
  OutputFile file(path);
  std::ostream& out = file.stream();
  out << std::setprecision(17);
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    for (Eigen::Index j = 0; j < m.cols(); ++j) out << (j ? "," : "") << m(i, j);
    out << '\n';
  }
  file.commit();
}

}  // namespace xbarsim
