#include "common/core/yaml_reader.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>

#include "common/core/error.h"
#include "common/core/input_file.h"

namespace nsim {
namespace {

std::string JoinKeys(const std::vector<std::string>& keys) {
  std::string out;
  for (size_t i = 0; i < keys.size(); ++i) out += (i ? ", " : "") + keys[i];
  return out;
}

// yaml-cpp keeps both entries of a duplicated key and operator[] finds the first, so a second
// "young_modulus:" further down would be silently ignored. This pass over the parser's events
// (before the document is built) remembers the keys of every open map and reports the second
// occurrence of one: "<source>:<line>: duplicate key <path> (first at line <n>)".
class DuplicateKeyFinder : public YAML::EventHandler {
 public:
  explicit DuplicateKeyFinder(const std::string& source) : source_(source) {}

  void OnDocumentStart(const YAML::Mark&) override { stack_.clear(); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { Leaf(mark, nullptr); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { Leaf(mark, nullptr); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                const std::string& value) override {
    Leaf(mark, &value);
  }
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    Open(false);
  }
  void OnSequenceEnd() override { Close(); }
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    Open(true);
  }
  void OnMapEnd() override { Close(); }

 private:
  struct Container {
    bool is_map = false;
    bool expect_key = true;  // maps: the next node is a key
    size_t index = 0;        // sequences: the next element's index
    std::string path;
    std::string key;                          // maps: the key of the current entry
    std::map<std::string, int> keys;          // maps: key -> line of its first occurrence
  };

  // key path of the node that starts now
  std::string ChildPath() const {
    if (stack_.empty()) return "";
    const Container& c = stack_.back();
    if (!c.is_map) return Str(c.path, "[", c.index, "]");
    if (c.expect_key) return c.path.empty() ? "<key>" : c.path + ".<key>";
    return c.path.empty() ? c.key : c.path + "." + c.key;
  }

  // a node was completed inside the top container
  void Completed() {
    if (stack_.empty()) return;
    Container& c = stack_.back();
    if (c.is_map) {
      c.expect_key = !c.expect_key;
    } else {
      ++c.index;
    }
  }

  void Leaf(const YAML::Mark& mark, const std::string* value) {
    if (!stack_.empty() && stack_.back().is_map && stack_.back().expect_key) {
      Container& c = stack_.back();
      c.key = value ? *value : "";
      const std::string path = c.path.empty() ? c.key : c.path + "." + c.key;
      const auto [it, inserted] = c.keys.emplace(c.key, mark.line + 1);
      if (!inserted)
        throw InputError(Str(source_, ":", mark.line + 1, ": duplicate key ", path,
                             " (first at line ", it->second, ")"));
    }
    Completed();
  }

  void Open(bool is_map) {
    Container c;
    c.is_map = is_map;
    c.path = ChildPath();
    const bool complex_key = !stack_.empty() && stack_.back().is_map && stack_.back().expect_key;
    if (complex_key) stack_.back().key = "<complex key>";
    stack_.push_back(std::move(c));
  }

  void Close() {
    if (!stack_.empty()) stack_.pop_back();
    Completed();
  }

  const std::string& source_;
  std::vector<Container> stack_;
};

YAML::Node LoadDocument(const std::string& text, const std::string& source) {
  try {
    {
      std::istringstream in(text);
      YAML::Parser parser(in);
      DuplicateKeyFinder finder(source);
      while (parser.HandleNextDocument(finder)) {
      }
    }
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(Str(source, ":", e.mark.line + 1, ":", e.mark.column + 1, ": ", e.msg));
  }
}

}  // namespace

YamlReader::YamlReader(std::shared_ptr<const std::string> source, std::string path,
                       std::unique_ptr<YAML::Node> node)
    : source_(std::move(source)), path_(std::move(path)), node_(std::move(node)) {}

YamlReader::~YamlReader() = default;

YamlReader::YamlReader(const YamlReader& other)
    : source_(other.source_),
      path_(other.path_),
      node_(std::make_unique<YAML::Node>(*other.node_)) {}

YamlReader& YamlReader::operator=(const YamlReader& other) {
  if (this != &other) {
    source_ = other.source_;
    path_ = other.path_;
    node_ = std::make_unique<YAML::Node>(*other.node_);  // copy the handle, never assign nodes
  }
  return *this;
}

YamlReader YamlReader::LoadFile(const std::string& path) {
  return LoadString(ReadInputFile(path, "file"), path);
}

YamlReader YamlReader::LoadString(const std::string& text, const std::string& source) {
  auto node = std::make_unique<YAML::Node>(LoadDocument(text, source));
  return YamlReader(std::make_shared<const std::string>(source), "", std::move(node));
}

std::string YamlReader::KeyPath(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

std::string YamlReader::Where(const std::string& key) const {
  return *source_ + ": " + KeyPath(key);
}

std::string YamlReader::Where() const { return path_.empty() ? *source_ : *source_ + ": " + path_; }

bool YamlReader::IsMap() const { return node_->IsMap(); }
bool YamlReader::IsSequence() const { return node_->IsSequence(); }
bool YamlReader::IsScalar() const { return node_->IsScalar(); }
bool YamlReader::IsNull() const { return !node_->IsDefined() || node_->IsNull(); }

size_t YamlReader::size() const {
  return node_->IsMap() || node_->IsSequence() ? node_->size() : 0;
}

bool YamlReader::Has(const std::string& key) const {
  if (!node_->IsMap()) return false;
  const YAML::Node& self = *node_;
  const YAML::Node child = self[key];
  return child.IsDefined() && !child.IsNull();
}

std::vector<std::string> YamlReader::Keys() const {
  std::vector<std::string> keys;
  if (!node_->IsMap()) return keys;
  for (const auto& entry : *node_) keys.push_back(entry.first.Scalar());
  return keys;
}

void YamlReader::CheckKeys(const std::vector<std::string>& known) const {
  if (IsNull()) return;
  if (!node_->IsMap()) Fail(Str("expected a map of keys, got ", Text()));
  for (const std::string& key : Keys())
    if (std::find(known.begin(), known.end(), key) == known.end())
      throw InputError(Str(Where(key), ": unknown key (known keys: ", JoinKeys(known), ")"));
}

YamlReader YamlReader::OptionalChild(const std::string& key) const {
  auto child = std::make_unique<YAML::Node>();
  if (node_->IsMap()) {
    const YAML::Node& self = *node_;
    const YAML::Node found = self[key];
    if (found.IsDefined()) child = std::make_unique<YAML::Node>(found);
  } else if (!IsNull()) {
    Fail(Str("expected a map of keys, got ", Text()));
  }
  return YamlReader(source_, KeyPath(key), std::move(child));
}

YamlReader YamlReader::Child(const std::string& key) const {
  if (!Has(key)) throw InputError(Str(Where(key), ": missing"));
  return OptionalChild(key);
}

YamlReader YamlReader::Element(size_t i) const {
  NSIM_CHECK(node_->IsSequence() && i < node_->size(), "element ", i, " of ", path_);
  const YAML::Node& self = *node_;
  return YamlReader(source_, Str(path_, "[", i, "]"), std::make_unique<YAML::Node>(self[i]));
}

std::string YamlReader::Text() const {
  if (IsNull()) return "nothing";
  if (node_->IsScalar()) return "'" + node_->Scalar() + "'";
  if (node_->IsSequence()) return Str("a list of ", node_->size());
  return "a map";
}

void YamlReader::Fail(const std::string& key, const std::string& message) const {
  throw InputError(Str(Where(key), ": ", message));
}

void YamlReader::Fail(const std::string& message) const {
  throw InputError(Str(Where(), ": ", message));
}

double YamlReader::AsDouble() const {
  if (!node_->IsScalar()) Fail(Str("expected a number, got ", Text()));
  const std::string& text = node_->Scalar();
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    Fail(Str("expected a number, got '", text, "'"));
  if (!std::isfinite(v)) Fail(Str("expected a finite number, got '", text, "'"));
  return v;
}

long YamlReader::AsInt() const {
  if (!node_->IsScalar()) Fail(Str("expected an integer, got ", Text()));
  const std::string& text = node_->Scalar();
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    Fail(Str("expected an integer, got '", text, "'"));
  return v;
}

uint64_t YamlReader::AsUint64() const {
  if (!node_->IsScalar()) Fail(Str("expected a non-negative integer, got ", Text()));
  const std::string& text = node_->Scalar();
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || text[0] == '-' || end != text.c_str() + text.size() || errno == ERANGE)
    Fail(Str("expected a non-negative integer, got '", text, "'"));
  return static_cast<uint64_t>(v);
}

bool YamlReader::AsBool() const {
  if (node_->IsScalar()) {
    std::string text = node_->Scalar();
    std::transform(text.begin(), text.end(), text.begin(), ::tolower);
    if (text == "true" || text == "yes" || text == "on") return true;
    if (text == "false" || text == "no" || text == "off") return false;
  }
  Fail(Str("expected true or false, got ", Text()));
}

std::string YamlReader::AsString() const {
  if (!node_->IsScalar()) Fail(Str("expected a text value, got ", Text()));
  return node_->Scalar();
}

std::vector<double> YamlReader::AsDoubles() const {
  if (!node_->IsSequence()) Fail(Str("expected a list of numbers, got ", Text()));
  std::vector<double> values;
  for (size_t i = 0; i < size(); ++i) values.push_back(Element(i).AsDouble());
  return values;
}

Eigen::Vector3d YamlReader::AsVector3() const {
  if (!node_->IsSequence() || node_->size() != 3)
    Fail(Str("expected a list of 3 numbers [x, y, z], got ", Text()));
  return Eigen::Vector3d(Element(0).AsDouble(), Element(1).AsDouble(), Element(2).AsDouble());
}

Eigen::Isometry3d YamlReader::AsPose() const {
  if (!node_->IsMap())
    Fail(Str("expected a pose {position: [x, y, z], rpy: [roll, pitch, yaw]}, got ", Text()));
  CheckKeys({"position", "rpy"});
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), rpy = Eigen::Vector3d::Zero();
  Read("position", &p);
  Read("rpy", &rpy);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  X.translation() = p;
  return X;
}

bool YamlReader::Read(const std::string& key, double* value) const {
  if (!Has(key)) return false;
  *value = Child(key).AsDouble();
  return true;
}

bool YamlReader::Read(const std::string& key, int* value) const {
  if (!Has(key)) return false;
  const long v = Child(key).AsInt();
  if (v < -2147483647L || v > 2147483647L) Fail(key, Str("integer out of range, got ", v));
  *value = static_cast<int>(v);
  return true;
}

bool YamlReader::Read(const std::string& key, uint64_t* value) const {
  if (!Has(key)) return false;
  *value = Child(key).AsUint64();
  return true;
}

bool YamlReader::Read(const std::string& key, bool* value) const {
  if (!Has(key)) return false;
  *value = Child(key).AsBool();
  return true;
}

bool YamlReader::Read(const std::string& key, std::string* value) const {
  if (!Has(key)) return false;
  *value = Child(key).AsString();
  return true;
}

bool YamlReader::Read(const std::string& key, Eigen::Vector3d* value) const {
  if (!Has(key)) return false;
  *value = Child(key).AsVector3();
  return true;
}

bool YamlReader::Read(const std::string& key, Eigen::Isometry3d* value) const {
  if (!Has(key)) return false;
  *value = Child(key).AsPose();
  return true;
}

bool YamlReader::Read(const std::string& key, std::vector<Eigen::Vector3d>* value) const {
  if (!Has(key)) return false;
  const YamlReader list = Child(key);
  if (!list.IsSequence()) list.Fail(Str("expected a list of [x, y, z] points, got ", list.Text()));
  std::vector<Eigen::Vector3d> points;
  for (size_t i = 0; i < list.size(); ++i) points.push_back(list.Element(i).AsVector3());
  *value = std::move(points);
  return true;
}

int YamlReader::ReadChoice(const std::string& key, const std::vector<std::string>& choices) const {
  if (!Has(key)) return -1;
  const std::string text = Child(key).AsString();
  for (size_t i = 0; i < choices.size(); ++i)
    if (choices[i] == text) return static_cast<int>(i);
  Fail(key, Str("expected one of ", JoinKeys(choices), ", got '", text, "'"));
}

void ValidateAs(const std::function<void()>& validate, const std::string& source,
                const std::string& from, const std::string& to) {
  try {
    validate();
  } catch (const InputError& e) {
    std::string what = e.what();
    if (what.compare(0, from.size(), from) == 0) what = to + what.substr(from.size());
    throw InputError(source + ": " + what);
  }
}

}  // namespace nsim
