#include "sw/common/cli_args.h"

#include "sw/common/errors.h"

namespace xbarsim {

CliArgs::CliArgs(int argc, char** argv, int first, const std::set<std::string>& value_flags,
                 const std::set<std::string>& switches) {
  std::set<std::string> vflags = value_flags;
  vflags.insert({"--config", "--json", "--csv"});
  for (int i = first; i < argc; ++i) {
    std::string a = argv[i];
    std::string value;
    bool has_inline = false;
    const auto eq = a.find('=');
    if (a.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = a.substr(eq + 1);
      a = a.substr(0, eq);
      has_inline = true;
    }
    if (a == "--set" || vflags.count(a)) {
      if (!has_inline) {
        if (i + 1 >= argc) throw InputError("option " + a + " needs a value");
        value = argv[++i];
      }
      if (a == "--set")
        sets_.push_back(value);
      else if (!values_.emplace(a, value).second)
        throw InputError("option " + a + " is given twice ('" + values_[a] + "' and '" + value + "'): give it once");
    } else if (switches.count(a)) {
      if (has_inline) throw InputError("option " + a + " takes no value");
      if (!values_.emplace(a, "1").second) throw InputError("option " + a + " is given twice: give it once");
    } else {
      std::string known = "--set --config --json --csv";
      for (const auto& f : value_flags) known += " " + f;
      for (const auto& f : switches) known += " " + f;
      throw InputError("unknown option '" + std::string(argv[i]) + "' (known: " + known + ")");
    }
  }
}

bool CliArgs::has(const std::string& flag) const { return values_.count(flag) > 0; }

std::string CliArgs::get(const std::string& flag, const std::string& fallback) const {
  auto it = values_.find(flag);
  return it == values_.end() ? fallback : it->second;
}

std::string CliArgs::require(const std::string& flag) const {
  auto it = values_.find(flag);
  if (it == values_.end()) throw InputError("missing required option " + flag);
  return it->second;
}

}  // namespace xbarsim
