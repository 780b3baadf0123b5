#include "common/ros2msg.hpp"

#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include "common/text_io.hpp"

namespace dynamap::tools::ros2msg {
namespace {

const std::set<std::string>& primitives() {
  static const std::set<std::string> p = {"bool",   "byte",    "char",    "int8",   "uint8",
                                          "int16",  "uint16",  "int32",   "uint32", "int64",
                                          "uint64", "float32", "float64", "string", "wstring"};
  return p;
}

std::string package_of(const std::string& type) {
  const auto slash = type.find('/');
  return slash == std::string::npos ? std::string() : type.substr(0, slash);
}

// One "type name [default]" line; constants ("type NAME=value") give false.
bool parse_field(const std::string& line, const std::string& owner, Field* f) {
  std::istringstream is(line);
  std::string type, name;
  is >> type >> name;
  if (name.empty() || name.find('=') != std::string::npos) return false;
  std::string rest;
  is >> rest;
  if (!rest.empty() && rest[0] == '=') return false;
  const auto bracket = type.find('[');
  if (bracket != std::string::npos) {
    const std::string inside = type.substr(bracket + 1, type.size() - bracket - 2);
    f->is_array = true;
    if (!inside.empty() && inside.rfind("<=", 0) != 0) {
      f->fixed = true;
      f->count = static_cast<std::uint32_t>(std::stoul(inside));
    }
    type = type.substr(0, bracket);
  }
  const auto bound = type.find("<=");
  if (bound != std::string::npos) type = type.substr(0, bound);  // bounded string
  f->name = name;
  if (primitives().count(type) != 0) {
    f->type = type;
  } else if (type == "Header") {
    f->type = "std_msgs/Header";
    f->is_message = true;
  } else {
    f->type =
        type.find('/') == std::string::npos ? package_of(owner) + "/" + type : normalise_type(type);
    f->is_message = true;
  }
  return true;
}

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return {};
  const auto b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

}  // namespace

std::string normalise_type(const std::string& name) {
  const auto p = name.find("/msg/");
  return p == std::string::npos ? name : name.substr(0, p) + "/" + name.substr(p + 5);
}

std::map<std::string, Definition> parse_schema(const std::string& root_type,
                                               const std::string& text) {
  std::map<std::string, Definition> defs;
  Definition current;
  current.name = normalise_type(root_type);
  std::istringstream is(text);
  std::string raw;
  while (std::getline(is, raw)) {
    std::string line = trim(raw);
    if (line.rfind("===", 0) == 0) {
      defs[current.name] = current;
      current = Definition{};
      continue;
    }
    if (line.rfind("MSG:", 0) == 0) {
      current.name = normalise_type(trim(line.substr(4)));
      continue;
    }
    // Comments; a '#' inside a string default or constant cannot matter to the layout.
    const auto hash = line.find('#');
    if (hash != std::string::npos) line = trim(line.substr(0, hash));
    if (line.empty()) continue;
    Field f;
    try {
      if (parse_field(line, current.name, &f)) current.fields.push_back(f);
    } catch (const std::exception&) {
      throw ToolError("schema of " + root_type + ": cannot read the line '" + line + "'");
    }
  }
  defs[current.name] = current;
  for (const auto& [name, def] : defs) {
    for (const Field& f : def.fields) {
      if (f.is_message && defs.count(f.type) == 0) {
        throw ToolError("schema of " + root_type + ": type " + f.type + " (field " + name + "." +
                        f.name + ") is not defined in the schema");
      }
    }
  }
  return defs;
}

const Value& Value::operator[](const std::string& name) const {
  for (const auto& [k, v] : fields) {
    if (k == name) return v;
  }
  throw ToolError("message has no field '" + name + "'");
}

bool Value::has(const std::string& name) const {
  for (const auto& field : fields) {
    if (field.first == name) return true;
  }
  return false;
}

double Value::number() const {
  switch (kind) {
    case Kind::kBool:
    case Kind::kInt:
      return static_cast<double>(i);
    case Kind::kUInt:
      return static_cast<double>(u);
    case Kind::kFloat:
      return f;
    default:
      throw ToolError("a number was expected");
  }
}

namespace {

Value primitive(const std::string& t, cdr::Reader& in) {
  Value v;
  if (t == "bool") {
    v.kind = Value::Kind::kBool;
    v.i = in.read<std::uint8_t>() != 0 ? 1 : 0;
  } else if (t == "int8") {
    // A number, not a character: the byte sign-extended by hand (no signed char conversion).
    const int b = in.read<std::uint8_t>();
    v.i = b < 128 ? b : b - 256;
  } else if (t == "uint8" || t == "byte" || t == "char") {
    v.kind = Value::Kind::kUInt;
    v.u = in.read<std::uint8_t>();
  } else if (t == "int16") {
    v.i = in.read<std::int16_t>();
  } else if (t == "uint16") {
    v.kind = Value::Kind::kUInt;
    v.u = in.read<std::uint16_t>();
  } else if (t == "int32") {
    v.i = in.read<std::int32_t>();
  } else if (t == "uint32") {
    v.kind = Value::Kind::kUInt;
    v.u = in.read<std::uint32_t>();
  } else if (t == "int64") {
    v.i = in.read<std::int64_t>();
    v.wide = true;
  } else if (t == "uint64") {
    v.kind = Value::Kind::kUInt;
    v.u = in.read<std::uint64_t>();
    v.wide = true;
  } else if (t == "float32") {
    v.kind = Value::Kind::kFloat;
    v.f = in.read<float>();
  } else if (t == "float64") {
    v.kind = Value::Kind::kFloat;
    v.f = in.read<double>();
  } else if (t == "string") {
    v.kind = Value::Kind::kString;
    v.s = in.string();
  } else {
    throw ToolError("type " + t + " is not supported");
  }
  return v;
}

Value decode_field(const std::map<std::string, Definition>& defs, const Field& f, cdr::Reader& in,
                   int depth);

Value decode_message(const std::map<std::string, Definition>& defs, const std::string& type,
                     cdr::Reader& in, int depth) {
  if (depth > 64) throw ToolError("messages nested more than 64 deep");
  const Definition& def = defs.at(type);
  Value v;
  v.kind = Value::Kind::kMessage;
  if (def.fields.empty()) in.read<std::uint8_t>();  // ROS 2 pads an empty message to one byte
  for (const Field& f : def.fields) v.fields.emplace_back(f.name, decode_field(defs, f, in, depth));
  return v;
}

Value decode_field(const std::map<std::string, Definition>& defs, const Field& f, cdr::Reader& in,
                   int depth) {
  auto one = [&]() {
    return f.is_message ? decode_message(defs, f.type, in, depth + 1) : primitive(f.type, in);
  };
  if (!f.is_array) return one();
  const std::uint32_t n = f.fixed ? f.count : in.length(1);
  Value v;
  if (f.type == "uint8" || f.type == "byte" || f.type == "char") {
    v.kind = Value::Kind::kBytes;
    const std::uint8_t* p = in.bytes(n);
    v.s.assign(reinterpret_cast<const char*>(p), n);
    return v;
  }
  if (n > in.left()) throw cdr::Error("CDR: array of " + std::to_string(n) + " elements overruns");
  v.kind = Value::Kind::kArray;
  v.items.reserve(n);
  for (std::uint32_t k = 0; k < n; ++k) v.items.push_back(one());
  return v;
}

void append_string(const std::string& s, std::string* out) {
  out->push_back('"');
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out->push_back('\\');
      out->push_back(ch);
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", c);
      out->append(buf);
    } else {
      out->push_back(ch);
    }
  }
  out->push_back('"');
}

}  // namespace

Value decode(const std::map<std::string, Definition>& defs, const std::string& root,
             cdr::Reader& in) {
  if (defs.count(root) == 0) throw ToolError("no definition of " + root);
  return decode_message(defs, root, in, 0);
}

void append_json(const Value& v, std::string* out) {
  char buf[40];
  switch (v.kind) {
    case Value::Kind::kBool:
      out->append(v.i != 0 ? "true" : "false");
      return;
    case Value::Kind::kInt:
      if (v.wide) out->push_back('"');
      out->append(std::to_string(v.i));
      if (v.wide) out->push_back('"');
      return;
    case Value::Kind::kUInt:
      if (v.wide) out->push_back('"');
      out->append(std::to_string(v.u));
      if (v.wide) out->push_back('"');
      return;
    case Value::Kind::kFloat:
      if (std::isfinite(v.f)) {
        std::snprintf(buf, sizeof(buf), "%.17g", v.f);
        out->append(buf);
      } else {
        append_string(std::isnan(v.f) ? "NaN" : (v.f > 0 ? "Infinity" : "-Infinity"), out);
      }
      return;
    case Value::Kind::kString:
      append_string(v.s, out);
      return;
    case Value::Kind::kBytes:
    case Value::Kind::kArray: {
      out->push_back('[');
      const std::size_t n = v.kind == Value::Kind::kBytes ? v.s.size() : v.items.size();
      for (std::size_t k = 0; k < n; ++k) {
        if (k > 0) out->push_back(',');
        if (v.kind == Value::Kind::kBytes) {
          out->append(std::to_string(static_cast<unsigned char>(v.s[k])));
        } else {
          append_json(v.items[k], out);
        }
      }
      out->push_back(']');
      return;
    }
    case Value::Kind::kMessage:
      out->push_back('{');
      for (std::size_t k = 0; k < v.fields.size(); ++k) {
        if (k > 0) out->push_back(',');
        append_string(v.fields[k].first, out);
        out->push_back(':');
        append_json(v.fields[k].second, out);
      }
      out->push_back('}');
      return;
  }
}

}  // namespace dynamap::tools::ros2msg
