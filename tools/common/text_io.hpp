// Small text helpers shared by the tools' file readers: line splitting, strict number parsing and
// errors that name the file and line. Tools report errors as ToolError and exit non-zero.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace dynamap::tools {

/// Error raised by the tools' readers and writers; the message names the file (and line).
class ToolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Where a parsed value came from, for error messages ("path:line").
struct TextLocation {
  std::string file;
  std::size_t line = 0;  ///< 1-based; 0 when the whole file is meant
  std::string str() const;
};

[[noreturn]] void fail_at(const TextLocation& where, const std::string& what);

/// Reads a whole text file into lines (without the line ends; a trailing '\r' is dropped).
std::vector<std::string> read_lines(const std::string& path);

/// Removes a '#' comment and surrounding blanks; empty result means "skip this line".
std::string strip_comment(const std::string& line);

/// Splits on spaces/tabs (TUM files) — empty fields are never produced.
std::vector<std::string> split_ws(const std::string& line);

/// Splits on commas (CSV files without quoting) — keeps empty fields.
std::vector<std::string> split_csv(const std::string& line);

/// Strict parsers: the whole field must be a finite number, else fail_at(where, ...).
double parse_double(const std::string& field, const TextLocation& where, const char* name);
long long parse_int(const std::string& field, const TextLocation& where, const char* name);

/// Time stamps: seconds as text; key() turns them into integer microseconds so that stamps
/// written by different programs (>= 6 decimals) compare exactly.
std::int64_t stamp_key(double seconds);

/// Joins a directory and a relative file name.
std::string join_path(const std::string& dir, const std::string& name);

bool file_exists(const std::string& path);

/// Creates a directory and any missing parents (like mkdir -p); throws ToolError naming
/// `what` and the path when it cannot.
void make_directories(const std::string& path, const char* what = "cannot create directory");

}  // namespace dynamap::tools
