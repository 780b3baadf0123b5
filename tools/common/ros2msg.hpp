// ROS 2 message definitions (the `ros2msg` schema text rosbag2 stores in MCAP: the root type's
// .msg text followed by each dependency after a line of '=' and "MSG: pkg/Type") and a generic
// CDR decoder driven by them, to a tree of values (and JSON, for the cross-check with Node.js).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common/cdr.hpp"

namespace dynamap::tools::ros2msg {

struct Field {
  std::string type;  ///< a primitive ("float64", "string", ...) or a message "pkg/Type"
  std::string name;
  bool is_message = false;
  bool is_array = false;
  bool fixed = false;  ///< T[N]: no length prefix
  std::uint32_t count = 0;
};

struct Definition {
  std::string name;  ///< "pkg/Type"
  std::vector<Field> fields;
};

/// "pkg/msg/Type" -> "pkg/Type" (both spellings occur).
std::string normalise_type(const std::string& name);

/// The definitions of a schema text, keyed by normalised name; the root gets `root_type`.
/// Throws ToolError on a malformed line or a type no definition provides.
std::map<std::string, Definition> parse_schema(const std::string& root_type,
                                               const std::string& text);

/// A decoded value: a primitive, a byte array (uint8/byte/char arrays), an array or a message.
struct Value {
  enum class Kind { kBool, kInt, kUInt, kFloat, kString, kBytes, kArray, kMessage };
  Kind kind = Kind::kInt;
  bool wide = false;  ///< 64-bit integer (written as a JSON string: exact beyond 2^53)
  std::int64_t i = 0;
  std::uint64_t u = 0;
  double f = 0.0;
  std::string s;                                      ///< string, or the bytes of kBytes
  std::vector<Value> items;                           ///< kArray
  std::vector<std::pair<std::string, Value>> fields;  ///< kMessage, in order

  /// A field of a message; throws ToolError naming it when absent.
  const Value& operator[](const std::string& name) const;
  bool has(const std::string& name) const;
  double number() const;  ///< any numeric kind as double
};

/// Decodes one message of type `root` (normalised). Throws cdr::Error / ToolError.
Value decode(const std::map<std::string, Definition>& defs, const std::string& root,
             cdr::Reader& in);

/// JSON text of a value (floats with 17 significant digits, 64-bit integers as strings).
void append_json(const Value& v, std::string* out);

}  // namespace dynamap::tools::ros2msg
