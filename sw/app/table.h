#pragma once
/// The one writer for what commands report: rows printed as an aligned table (streaming,
/// a row at a time) and the same rows as CSV. JSON comes from each result's to_json().
#include <cstdio>
#include <ostream>
#include <string>
#include <variant>
#include <vector>

namespace xbarsim {

class Table {
 public:
  using Cell = std::variant<long long, double, std::string>;
  struct Column {
    std::string name;
    int width;          ///< printed width (negative = left aligned)
    int precision = 4;  ///< digits after the point for doubles (table); CSV keeps 12 significant
  };
  explicit Table(std::vector<Column> columns) : columns_(std::move(columns)) {}

  void print_header(std::FILE* out) const;
  void print_row(std::FILE* out, const std::vector<Cell>& row) const;
  void csv_header(std::ostream& os) const;
  void csv_row(std::ostream& os, const std::vector<Cell>& row) const;

 private:
  std::vector<Column> columns_;
};

}  // namespace xbarsim
