// Internal to host/io: text helpers shared by the recording importers (import.cpp, import_csv.cpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace imuforge::io::detail {

constexpr double kG = 9.80665;  // standard gravity, m/s² (nominal LSBs of imported recordings)
// File name without folder and extension.
std::string base_name(const std::string& p);
// Splits on any run of the separators (empty fields never appear).
void split(const std::string& line, const char* seps, std::vector<std::string>& out);
// A finite number, or LogError "<where>: expected a number, got '<s>'".
double to_double(const std::string& s, const std::string& where);
// An integer in [lo, hi], or LogError naming where.
std::int32_t to_count(const std::string& s, double lo, double hi, const std::string& where);

}  // namespace imuforge::io::detail
