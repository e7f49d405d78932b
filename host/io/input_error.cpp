#include "host/io/input_error.h"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include <nlohmann/json.hpp>

namespace imuforge::io {

BadInput::~BadInput() = default;

bool is_input_error(const std::exception& e) {
  return dynamic_cast<const BadInput*>(&e) != nullptr || dynamic_cast<const std::invalid_argument*>(&e) != nullptr ||
         dynamic_cast<const nlohmann::json::exception*>(&e) != nullptr;
}

nlohmann::json read_json_file(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw InputError(path + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode) && static_cast<std::uintmax_t>(st.st_size) > kMaxJsonFileBytes) {
    std::fclose(f);  // without reading it (a sparse 2 GB file costs nothing)
    throw InputError(path + ": larger than " + std::to_string(kMaxJsonFileBytes >> 20) + " MiB: not a configuration file");
  }
  std::string text;
  char buf[65536];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) {
    if (text.size() + n > kMaxJsonFileBytes) {
      std::fclose(f);
      throw InputError(path + ": larger than " + std::to_string(kMaxJsonFileBytes >> 20) +
                       " MiB: not a configuration file");
    }
    text.append(buf, n);
  }
  const bool err = std::ferror(f) != 0;
  std::fclose(f);
  if (err) throw InputError(path + ": read error");
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) throw InputError(path + ": empty file (expected JSON)");
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is 1-based and points just past the offending character.
    const std::size_t at = e.byte == 0 ? 0 : std::min<std::size_t>(e.byte - 1, text.size());
    std::size_t line = 1, col = 1;
    for (std::size_t i = 0; i < at; ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    std::string what = e.what();
    // "[json.exception.parse_error.101] parse error at line 3, column 5: syntax error while parsing ..."
    const auto colon = what.find(": ", what.find("parse error"));
    if (colon != std::string::npos) what = what.substr(colon + 2);
    throw InputError(path + ":" + std::to_string(line) + ":" + std::to_string(col) + ": malformed JSON: " + what);
  }
}

bool read_line_bounded(std::istream& in, std::string& line, const std::string& where) {
  line.clear();
  std::streambuf* sb = in.rdbuf();
  bool any = false;
  for (;;) {
    const int c = sb->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      in.setstate(any ? std::ios::eofbit : (std::ios::eofbit | std::ios::failbit));
      break;
    }
    any = true;
    if (c == '\n') break;
    if (line.size() >= kMaxLineBytes) throw InputError(where + ": line longer than 1 MiB");
    line.push_back(static_cast<char>(c));
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return any;
}

std::string quote_for_message(const std::string& text) {
  std::string q = "'";
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (i == 40) {
      q += "...";
      break;
    }
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f) {
      q += static_cast<char>(c);
    } else {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", c);
      q += b;
    }
  }
  return q + "'";
}

}  // namespace imuforge::io
