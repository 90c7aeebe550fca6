#pragma once
// A small typed access layer over yaml-cpp for scenario files: every read names the key path
// and the file in its error ("scenario.yaml: patient.liver.young_modulus: expected a number,
// got 'abc'"), optional keys keep the config struct's default, and CheckKeys() catches typos
// (unknown keys). Only mains and their loaders use it: libraries take config structs.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace YAML {
class Node;
}

namespace nsim {

/// One node of a parsed YAML document together with where it came from (file and key path).
/// Cheap to copy (shares the document). Every error is an InputError whose text starts with
/// "<source>: <key path>: ".
class YamlReader {
 public:
  /// Parses the file; InputError when it cannot be read or is not valid YAML
  /// ("<path>:<line>:<column>: <what the parser says>"). `path` is the source in messages.
  static YamlReader LoadFile(const std::string& path);
  /// Parses `text`; `source` names it in messages.
  static YamlReader LoadString(const std::string& text, const std::string& source);

  ~YamlReader();
  YamlReader(const YamlReader& other);
  YamlReader& operator=(const YamlReader& other);

  const std::string& source() const { return *source_; }
  /// Dotted key path of this node from the document root ("" for the root, "patient.liver",
  /// "patient.markers[2]").
  const std::string& key_path() const { return path_; }
  /// Key path of a child: key_path() + "." + key (or key at the root).
  std::string KeyPath(const std::string& key) const;
  /// "<source>: <KeyPath(key)>", the prefix of every message about that child.
  std::string Where(const std::string& key) const;
  /// "<source>: <key_path()>" (or just the source at the root).
  std::string Where() const;

  bool IsMap() const;
  bool IsSequence() const;
  bool IsScalar() const;
  bool IsNull() const;  ///< absent or explicitly null
  /// Number of elements of a sequence or entries of a map (0 otherwise).
  size_t size() const;

  /// True if this is a map with `key` present and not null.
  bool Has(const std::string& key) const;
  /// The keys of a map in document order (empty for other kinds).
  std::vector<std::string> Keys() const;
  /// Throws InputError "<where>: unknown key (known keys: a, b, c)" for the first key of this
  /// map that is not in `known`; also when this node is present but not a map.
  void CheckKeys(const std::vector<std::string>& known) const;

  /// The child under `key`; InputError "<where>: missing" when absent.
  YamlReader Child(const std::string& key) const;
  /// The child under `key`, possibly absent (IsNull()).
  YamlReader OptionalChild(const std::string& key) const;
  /// Element i of a sequence (key path "<path>[i]"); precondition i < size().
  YamlReader Element(size_t i) const;

  // Conversions of this node; InputError "<where>: expected ..., got '...'".
  double AsDouble() const;                ///< a finite number
  long AsInt() const;                     ///< an integer
  uint64_t AsUint64() const;              ///< a non-negative integer
  bool AsBool() const;                    ///< true/false (also yes/no, on/off)
  std::string AsString() const;           ///< any scalar
  Eigen::Vector3d AsVector3() const;      ///< a list of 3 finite numbers
  std::vector<double> AsDoubles() const;  ///< a list of finite numbers
  /// A pose: a map {position: [x, y, z] (m), rpy: [roll, pitch, yaw] (rad)}, both optional
  /// (zero), R = Rz(yaw) Ry(pitch) Rx(roll) (fixed axes x, then y, then z).
  Eigen::Isometry3d AsPose() const;

  // Optional reads of a child: when `key` is present, convert it into *value and return true;
  // when absent, leave *value (the default) and return false.
  bool Read(const std::string& key, double* value) const;
  bool Read(const std::string& key, int* value) const;
  bool Read(const std::string& key, uint64_t* value) const;
  bool Read(const std::string& key, bool* value) const;
  bool Read(const std::string& key, std::string* value) const;
  bool Read(const std::string& key, Eigen::Vector3d* value) const;
  bool Read(const std::string& key, Eigen::Isometry3d* value) const;
  bool Read(const std::string& key, std::vector<Eigen::Vector3d>* value) const;

  /// Reads `key` as one of `choices` (InputError "<where>: expected one of a, b, got 'x'");
  /// returns its index, or -1 when absent.
  int ReadChoice(const std::string& key, const std::vector<std::string>& choices) const;

  /// Throws InputError "<where>: <message>" about child `key`.
  [[noreturn]] void Fail(const std::string& key, const std::string& message) const;
  /// Throws InputError "<where>: <message>" about this node.
  [[noreturn]] void Fail(const std::string& message) const;

 private:
  YamlReader(std::shared_ptr<const std::string> source, std::string path,
             std::unique_ptr<YAML::Node> node);
  std::string Text() const;  // scalar text for messages, or a description of the node kind

  std::shared_ptr<const std::string> source_;
  std::string path_;
  std::unique_ptr<YAML::Node> node_;
};

/// Runs `validate` (a config struct's Validate()) and rewrites the key prefix of its InputError:
/// a message starting with `from` ("fem.") is rethrown starting with `to` ("patient.liver."),
/// and every message is prefixed by "<source>: ". Other exceptions pass through.
void ValidateAs(const std::function<void()>& validate, const std::string& source,
                const std::string& from, const std::string& to);

}  // namespace nsim
