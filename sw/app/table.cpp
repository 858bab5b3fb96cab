#include "sw/app/table.h"

#include <cstdlib>
#include <iomanip>

#include "sw/common/errors.h"

namespace xbarsim {

void Table::print_header(std::FILE* out) const {
  for (size_t c = 0; c < columns_.size(); ++c)
    std::fprintf(out, "%s%*s", c ? " " : "", columns_[c].width, columns_[c].name.c_str());
  std::fprintf(out, "\n");
}

void Table::print_row(std::FILE* out, const std::vector<Cell>& row) const {
  if (row.size() != columns_.size()) throw std::logic_error("table row has the wrong number of cells");
  for (size_t c = 0; c < row.size(); ++c) {
    const Column& col = columns_[c];
    std::fprintf(out, "%s", c ? " " : "");
    if (const auto* i = std::get_if<long long>(&row[c]))
      std::fprintf(out, "%*lld", col.width, *i);
    else if (const auto* d = std::get_if<double>(&row[c]))
      std::fprintf(out, "%*.*f", col.width, col.precision, *d);
    else
      std::fprintf(out, "%*s", col.width, std::get<std::string>(row[c]).c_str());
  }
  std::fprintf(out, "\n");
  std::fflush(out);
}

void Table::csv_header(std::ostream& os) const {
  for (size_t c = 0; c < columns_.size(); ++c) os << (c ? "," : "") << columns_[c].name;
  os << "\n";
}

void Table::csv_row(std::ostream& os, const std::vector<Cell>& row) const {
  os << std::setprecision(12);
  for (size_t c = 0; c < row.size(); ++c) {
    os << (c ? "," : "");
    std::visit([&](const auto& v) { os << v; }, row[c]);
  }
  os << "\n";
}

}  // namespace xbarsim
