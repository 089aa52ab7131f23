// A tiny JSON reader for the reference vectors of ../shared/reference (test-only, no
// dependency). Supports what those files use: objects, arrays, numbers, strings (with the
// common escapes), true/false/null. Errors throw std::runtime_error with the byte offset.
#pragma once
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace json_lite {

struct Value {
  enum class Kind { Null, Bool, Number, String, Array, Object };
  Kind kind = Kind::Null;
  bool boolean = false;
  double number = 0.0;
  std::string string;
  std::vector<Value> array;
  std::map<std::string, Value> object;

  const Value& operator[](const std::string& key) const {
    if (kind != Kind::Object) throw std::runtime_error("json_lite: not an object (key '" + key + "')");
    auto it = object.find(key);
    if (it == object.end()) throw std::runtime_error("json_lite: missing key '" + key + "'");
    return it->second;
  }
  const Value& operator[](std::size_t k) const {
    if (kind != Kind::Array) throw std::runtime_error("json_lite: not an array");
    return array.at(k);
  }
  std::size_t size() const { return kind == Kind::Array ? array.size() : object.size(); }
  double num() const {
    if (kind != Kind::Number) throw std::runtime_error("json_lite: not a number");
    return number;
  }
  // Flattens a (nested) array of numbers in row-major order.
  void flatten_into(std::vector<double>& out) const {
    if (kind == Kind::Number) {
      out.push_back(number);
    } else if (kind == Kind::Array) {
      for (const auto& v : array) v.flatten_into(out);
    } else {
      throw std::runtime_error("json_lite: flatten of a non-numeric value");
    }
  }
  std::vector<double> flatten() const {
    std::vector<double> out;
    flatten_into(out);
    return out;
  }
};

class Parser {
 public:
  explicit Parser(const std::string& text) : s_(text) {}
  Value parse() {
    Value v = value();
    ws();
    if (pos_ != s_.size()) fail("trailing characters");
    return v;
  }

 private:
  [[noreturn]] void fail(const char* what) const {
    throw std::runtime_error(std::string("json_lite: ") + what + " at offset " + std::to_string(pos_));
  }
  void ws() {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\n' || s_[pos_] == '\r' || s_[pos_] == '\t'))
      ++pos_;
  }
  char peek() {
    ws();
    if (pos_ >= s_.size()) fail("unexpected end");
    return s_[pos_];
  }
  void expect(char c) {
    if (peek() != c) fail("unexpected character");
    ++pos_;
  }
  bool literal(const char* lit) {
    const std::string l(lit);
    if (s_.compare(pos_, l.size(), l) == 0) {
      pos_ += l.size();
      return true;
    }
    return false;
  }
  Value value() {
    const char c = peek();
    Value v;
    if (c == '{') {
      v.kind = Value::Kind::Object;
      ++pos_;
      if (peek() == '}') {
        ++pos_;
        return v;
      }
      for (;;) {
        std::string key = str();
        expect(':');
        v.object.emplace(std::move(key), value());
        if (peek() == ',') {
          ++pos_;
          continue;
        }
        expect('}');
        return v;
      }
    }
    if (c == '[') {
      v.kind = Value::Kind::Array;
      ++pos_;
      if (peek() == ']') {
        ++pos_;
        return v;
      }
      for (;;) {
        v.array.push_back(value());
        if (peek() == ',') {
          ++pos_;
          continue;
        }
        expect(']');
        return v;
      }
    }
    if (c == '"') {
      v.kind = Value::Kind::String;
      v.string = str();
      return v;
    }
    if (literal("true")) {
      v.kind = Value::Kind::Bool;
      v.boolean = true;
      return v;
    }
    if (literal("false")) {
      v.kind = Value::Kind::Bool;
      return v;
    }
    if (literal("null")) return v;
    // number: strtod accepts a superset of JSON numbers, which is fine for trusted files
    const char* begin = s_.c_str() + pos_;
    char* end = nullptr;
    v.number = std::strtod(begin, &end);
    if (end == begin) fail("bad value");
    v.kind = Value::Kind::Number;
    pos_ += static_cast<std::size_t>(end - begin);
    return v;
  }
  std::string str() {
    expect('"');
    std::string out;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      char c = s_[pos_++];
      if (c == '\\') {
        if (pos_ >= s_.size()) fail("bad escape");
        const char e = s_[pos_++];
        switch (e) {
          case 'n': out += '\n'; break;
          case 't': out += '\t'; break;
          case 'r': out += '\r'; break;
          case 'b': out += '\b'; break;
          case 'f': out += '\f'; break;
          case 'u':  // keep \uXXXX as-is: the reference files only use it in prose
            out += "\\u";
            break;
          default: out += e;  // \" \\ \/
        }
      } else {
        out += c;
      }
    }
    if (pos_ >= s_.size()) fail("unterminated string");
    ++pos_;
    return out;
  }
  const std::string& s_;
  std::size_t pos_ = 0;
};

inline Value parse(const std::string& text) { return Parser(text).parse(); }

inline Value load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("json_lite: cannot open " + path);
  std::stringstream ss;
  ss << in.rdbuf();
  return parse(ss.str());
}

}  // namespace json_lite
