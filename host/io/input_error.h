// Bad input: a file or value the user handed the program is malformed. Every parser reports it with one
// message naming the file and the line or key, and the `imuforge` program exits with code 2 for it
// (host/app/command.h), as opposed to 1 (the work ran and failed) and 3 (a peer failed).
//
//   throw io::InputError(path + ":" + std::to_string(line) + ": column 3 (temp_C): not a number");
//   catch (const std::exception& e) { return io::is_input_error(e) ? 2 : 1; }
//
// Errors that are partly about input (a journal's corruption, but not its failing fsync) carry the
// BadInput mark by also deriving from it, next to their own exception type.
#pragma once

#include <cstdint>
#include <exception>
#include <istream>
#include <stdexcept>
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace imuforge::io {

// Mark of an exception caused by bad input (mixin; derive from it next to the exception type).
class BadInput {
 public:
  virtual ~BadInput();
};

class InputError : public std::runtime_error, public BadInput {
 public:
  using std::runtime_error::runtime_error;
};

// True for a marked exception, std::invalid_argument (the JSON loaders' convention: message names the
// key) and nlohmann::json::exception (malformed JSON, wrong type).
bool is_input_error(const std::exception& e);

// Largest JSON input file read (campaign, sensor, model, station, register map, cal.json): far above any
// real one (the largest example is a few kB), small enough that a hostile file cannot exhaust memory.
constexpr std::uintmax_t kMaxJsonFileBytes = 64u << 20;

// Reads and parses a JSON file. Throws InputError "PATH: cannot open", "PATH: larger than 64 MiB",
// "PATH: empty file", "PATH:LINE:COL: malformed JSON: <what>" (line/column of the parse error).
nlohmann::json read_json_file(const std::string& path);

// Longest text line any line-oriented input may have (logs, imports, journals): a "2 GB line" is refused
// after 1 MiB instead of being read into memory.
constexpr std::size_t kMaxLineBytes = 1u << 20;

// std::getline with that bound: false at end of input; throws InputError "WHERE: line longer than 1 MiB".
// A trailing '\r' is removed.
bool read_line_bounded(std::istream& in, std::string& line, const std::string& where);

// A piece of input quoted for a one-line message: at most 40 characters, control and non-ASCII bytes as
// \xNN (a binary file given as text must not break the message's line).
std::string quote_for_message(const std::string& text);

}  // namespace imuforge::io
