#include "common/results.hpp"

#include <map>

#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

// Column lookup by header name.
class CsvTable {
 public:
  CsvTable(const std::string& path, const std::vector<const char*>& required) : path_(path) {
    lines_ = read_lines(path);
    while (header_line_ < lines_.size() && strip_comment(lines_[header_line_]).empty()) {
      ++header_line_;
    }
    if (header_line_ == lines_.size()) fail_at({path, 0}, "empty file (no header line)");
    const auto names = split_csv(lines_[header_line_]);
    for (std::size_t i = 0; i < names.size(); ++i) columns_[names[i]] = i;
    for (const char* name : required) {
      if (columns_.count(name) == 0) {
        fail_at({path, header_line_ + 1}, std::string("header has no column '") + name + "'");
      }
    }
  }

  bool has(const char* name) const { return columns_.count(name) != 0; }

  template <class F>
  void for_each_row(F&& f) const {
    for (std::size_t i = header_line_ + 1; i < lines_.size(); ++i) {
      if (strip_comment(lines_[i]).empty()) continue;
      const TextLocation at{path_, i + 1};
      const auto fields = split_csv(lines_[i]);
      if (fields.size() < columns_.size()) {
        fail_at(at, "expected " + std::to_string(columns_.size()) + " fields, got " +
                        std::to_string(fields.size()));
      }
      f(fields, at);
    }
  }

  const std::string& field(const std::vector<std::string>& fields, const char* name) const {
    return fields[columns_.at(name)];
  }
  double num(const std::vector<std::string>& fields, const char* name,
             const TextLocation& at) const {
    return parse_double(field(fields, name), at, name);
  }
  int integer(const std::vector<std::string>& fields, const char* name,
              const TextLocation& at) const {
    return static_cast<int>(parse_int(field(fields, name), at, name));
  }

 private:
  std::string path_;
  std::vector<std::string> lines_;
  std::size_t header_line_ = 0;
  std::map<std::string, std::size_t> columns_;
};

}  // namespace

std::vector<TrackRow> read_tracks_csv(const std::string& path) {
  const CsvTable t(
      path, {"stamp", "id", "x", "y", "z", "vx", "vy", "vz", "sx", "sy", "sz", "dynamic", "path"});
  const bool with_sigma = t.has("svx") && t.has("svy");
  std::vector<TrackRow> rows;
  t.for_each_row([&](const std::vector<std::string>& f, const TextLocation& at) {
    TrackRow r;
    r.stamp = t.num(f, "stamp", at);
    r.stamp_text = t.field(f, "stamp");
    r.id = t.integer(f, "id", at);
    r.center = {t.num(f, "x", at), t.num(f, "y", at), t.num(f, "z", at)};
    r.velocity = {t.num(f, "vx", at), t.num(f, "vy", at), t.num(f, "vz", at)};
    r.size = {t.num(f, "sx", at), t.num(f, "sy", at), t.num(f, "sz", at)};
    const int dyn = t.integer(f, "dynamic", at);
    if (dyn != 0 && dyn != 1) fail_at(at, "dynamic must be 0 or 1");
    r.dynamic = dyn == 1;
    r.path = t.integer(f, "path", at);
    if (with_sigma) r.velocity_sigma = {t.num(f, "svx", at), t.num(f, "svy", at)};
    rows.push_back(r);
  });
  return rows;
}

std::vector<PredictionRow> read_predictions_csv(const std::string& path) {
  const CsvTable t(path, {"stamp", "id", "path", "probability", "k", "t", "x", "y", "z"});
  std::vector<PredictionRow> rows;
  t.for_each_row([&](const std::vector<std::string>& f, const TextLocation& at) {
    PredictionRow r;
    r.stamp = t.num(f, "stamp", at);
    r.stamp_text = t.field(f, "stamp");
    r.id = t.integer(f, "id", at);
    r.path = t.integer(f, "path", at);
    r.probability = t.num(f, "probability", at);
    r.k = t.integer(f, "k", at);
    r.t = t.num(f, "t", at);
    r.position = {t.num(f, "x", at), t.num(f, "y", at), t.num(f, "z", at)};
    rows.push_back(r);
  });
  return rows;
}

void write_prediction_rows(std::ostream& out, const std::string& stamp_text,
                           const PathPrediction& p) {
  const int path = p.any_free ? static_cast<int>(p.chosen) : -1;
  for (std::size_t k = 0; k < p.num_samples; ++k) {
    out << stamp_text << "," << p.track_id << "," << path << "," << p.probability[p.chosen] << ","
        << k << "," << p.time[k] << "," << p.position[k].x() << "," << p.position[k].y() << ","
        << p.position[k].z() << "\n";
  }
}

}  // namespace dynamap::tools
