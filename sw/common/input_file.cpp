#include "sw/common/input_file.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <mutex>
#include <vector>

#include "sw/common/errors.h"

namespace xbarsim {

namespace {

struct Registered {
  dev_t dev;
  ino_t ino;
  InputFile file;
};

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}

std::vector<Registered>& registry() {
  static std::vector<Registered> r;
  return r;
}

}  // namespace

void register_input(const std::string& path, const std::string& role) {
  struct stat st;
  if (path.empty() || stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return;
  std::lock_guard<std::mutex> lock(registry_mutex());
  for (const Registered& r : registry())
    if (r.dev == st.st_dev && r.ino == st.st_ino) return;  // the first role names it
  registry().push_back({st.st_dev, st.st_ino, {path, role}});
}

std::optional<InputFile> registered_input(const std::string& path) {
  struct stat st;
  if (path.empty() || stat(path.c_str(), &st) != 0) return std::nullopt;
  std::lock_guard<std::mutex> lock(registry_mutex());
  for (const Registered& r : registry())
    if (r.dev == st.st_dev && r.ino == st.st_ino) return r.file;
  return std::nullopt;
}

bool same_file(const std::string& a, const std::string& b) {
  struct stat sa, sb;
  return stat(a.c_str(), &sa) == 0 && stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

void open_as_input(const std::string& path, const std::string& role) {
  struct stat st;
  if (stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
    throw InputError(role + " '" + path + "' is a directory; give a file");
  register_input(path, role);
}

LineRead read_line(std::istream& in, std::string& line, size_t max_bytes) {
  line.clear();
  std::streambuf* sb = in.rdbuf();
  for (;;) {
    const int c = sb->sbumpc();
    if (c == std::char_traits<char>::eof()) return line.empty() ? LineRead::End : LineRead::Unfinished;
    if (c == '\n') return LineRead::Line;
    line.push_back(static_cast<char>(c));
    if (line.size() > max_bytes) return LineRead::TooLong;
  }
}

std::string read_input_file(const std::string& path, const std::string& role, size_t max_bytes) {
  open_as_input(path, role);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot open " + role + " '" + path + "': " + std::strerror(errno));
  std::string text;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<size_t>(in.gcount()));
    if (text.size() > max_bytes)
      throw InputError(
          role + " '" + path + "' holds more than " +
          (max_bytes >= (1u << 20) ? std::to_string(max_bytes >> 20) + " MiB" : std::to_string(max_bytes) + " bytes") +
          ": not a file of this kind (or a device that never ends)");
  }
  if (in.bad()) throw InputError("cannot read " + role + " '" + path + "'");
  return text;
}

}  // namespace xbarsim
