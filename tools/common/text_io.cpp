#include "common/text_io.hpp"

#include <sys/stat.h>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace dynamap::tools {

std::string TextLocation::str() const {
  return line > 0 ? file + ":" + std::to_string(line) : file;
}

void fail_at(const TextLocation& where, const std::string& what) {
  throw ToolError(where.str() + ": " + what);
}

std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ToolError(path + ": cannot open file");
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  if (in.bad()) throw ToolError(path + ": read error");
  return lines;
}

std::string strip_comment(const std::string& line) {
  std::string s = line.substr(0, line.find('#'));
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return {};
  const auto last = s.find_last_not_of(" \t");
  return s.substr(first, last - first + 1);
}

std::vector<std::string> split_ws(const std::string& line) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    std::string field =
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const auto a = field.find_first_not_of(" \t");
    const auto b = field.find_last_not_of(" \t");
    out.push_back(a == std::string::npos ? std::string() : field.substr(a, b - a + 1));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

double parse_double(const std::string& field, const TextLocation& where, const char* name) {
  if (field.empty()) fail_at(where, std::string("empty field '") + name + "'");
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(field.c_str(), &end);
  if (end != field.c_str() + field.size() || errno == ERANGE || !std::isfinite(v)) {
    fail_at(where, std::string("field '") + name + "' is not a finite number: '" + field + "'");
  }
  return v;
}

long long parse_int(const std::string& field, const TextLocation& where, const char* name) {
  if (field.empty()) fail_at(where, std::string("empty field '") + name + "'");
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(field.c_str(), &end, 10);
  if (end != field.c_str() + field.size() || errno == ERANGE) {
    fail_at(where, std::string("field '") + name + "' is not an integer: '" + field + "'");
  }
  return v;
}

std::int64_t stamp_key(double seconds) {
  return std::llround(seconds * 1e6);
}

std::string join_path(const std::string& dir, const std::string& name) {
  if (dir.empty() || (!name.empty() && name.front() == '/')) return name;
  return dir.back() == '/' ? dir + name : dir + "/" + name;
}

void make_directories(const std::string& path, const char* what) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path, ec)) throw ToolError(path + ": " + what);
}

bool file_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

}  // namespace dynamap::tools
