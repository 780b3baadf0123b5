#include "dynamap/core/parameter.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace dynamap {
namespace {

// "12", "0.01", "1e+06": short, exact enough for a range.
int print_number(char* buf, std::size_t size, double v) noexcept {
  return std::snprintf(buf, size, "%.6g", v);
}

}  // namespace

bool param_in_range(ParamKind kind, double min, double max, bool min_open, bool max_open,
                    const ParamChoice* choices, std::size_t choice_count, double v) noexcept {
  if (!std::isfinite(v)) return false;
  if (min_open ? !(v > min) : !(v >= min)) return false;
  if (max_open ? !(v < max) : !(v <= max)) return false;
  if (kind == ParamKind::kEnum) {
    for (std::size_t i = 0; i < choice_count; ++i) {
      if (static_cast<double>(choices[i].value) == v) return true;
    }
    return false;
  }
  return true;
}

const char* param_range_text(ParamKind kind, double min, double max, bool min_open, bool max_open,
                             const char* unit, const ParamChoice* choices, std::size_t choice_count,
                             char* buf, std::size_t size) noexcept {
  if (size == 0) return buf;
  buf[0] = '\0';
  std::size_t at = 0;
  const auto put = [&](int n) {
    at = n < 0 ? at : std::min(size - 1, at + static_cast<std::size_t>(n));
  };
  if (kind == ParamKind::kBool) {
    put(std::snprintf(buf, size, "true or false"));
    return buf;
  }
  if (kind == ParamKind::kEnum) {
    for (std::size_t i = 0; i < choice_count; ++i) {
      put(std::snprintf(buf + at, size - at, "%s%s",
                        i == 0                  ? ""
                        : i + 1 == choice_count ? " or "
                                                : ", ",
                        choices[i].name));
    }
    return buf;
  }
  const bool lo = std::isfinite(min);
  const bool hi = std::isfinite(max);
  if (lo && hi) {
    put(std::snprintf(buf, size, "%c", min_open ? '(' : '['));
    put(print_number(buf + at, size - at, min));
    put(std::snprintf(buf + at, size - at, ", "));
    put(print_number(buf + at, size - at, max));
    put(std::snprintf(buf + at, size - at, "%c", max_open ? ')' : ']'));
  } else if (lo) {
    put(std::snprintf(buf, size, "%s ", min_open ? ">" : ">="));
    put(print_number(buf + at, size - at, min));
  } else if (hi) {
    put(std::snprintf(buf, size, "%s ", max_open ? "<" : "<="));
    put(print_number(buf + at, size - at, max));
  } else {
    put(std::snprintf(buf, size, "finite"));
  }
  if (unit[0] != '\0' && (lo || hi)) put(std::snprintf(buf + at, size - at, " %s", unit));
  return buf;
}

}  // namespace dynamap
