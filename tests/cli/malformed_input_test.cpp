// The malformed-input table, through the real CLI (docs/formats.md "What a bad file gets").
//
// For every file a user can hand `imuforge` (logs CSV and binary, both imports, campaign, sensor,
// model, station, register map, cal.json, sigma spec, the run journal), each broken input must give:
//   - exit code 2 (not a crash, not 1),
//   - exactly one line on stderr, naming the file and the line, column or key, and what is wrong,
//   - the output directory unchanged (no partial output; a file already there is left as it was).
// The table is printed (one row per case) so that its size is a figure: `ctest -R cli_malformed -V`.
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "firmware/common/crc32.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace cli_malformed_input_test {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

const std::string kWork = std::string(IMUFORGE_BINARY_DIR) + "/cli_malformed";
std::string ex(const std::string& f) { return std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/" + f; }
std::string map_file(const std::string& f) { return std::string(IMUFORGE_SOURCE_DIR) + "/host/fixture/maps/" + f; }

std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}
void put(const std::string& p, const std::string& s) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f << s;
}
// A file of `bytes` bytes after `head`, without storing them: the rest is a hole (reads as NULs, no '\n').
void put_sparse(const std::string& p, const std::string& head, off_t bytes) {
  put(p, head);
  ASSERT_EQ(::truncate(p.c_str(), static_cast<off_t>(head.size()) + bytes), 0);
}

struct CliRun {
  int code = -1;
  std::string err;
};
CliRun run(const std::string& args) {
  const std::string errf = kWork + "/stderr.txt";
  const int rc = std::system((std::string(IMUFORGE_BIN) + " " + args + " >/dev/null 2>" + errf).c_str());
  CliRun r;
  r.code = WIFEXITED(rc) ? WEXITSTATUS(rc) : 128 + WTERMSIG(rc);
  r.err = slurp(errf);
  return r;
}

// Names, sizes and contents of everything under a directory.
std::map<std::string, std::string> snapshot(const std::string& dir) {
  std::map<std::string, std::string> m;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    // Contents up to 64 MiB; beyond (the sparse 2 GiB inputs) the size stands for them.
    m[e.path().string()] = !e.is_regular_file()           ? "<dir>"
                           : e.file_size() > (64u << 20) ? std::to_string(e.file_size())
                                                         : slurp(e.path());
  }
  return m;
}

// --- the good inputs the broken ones are made from -------------------------------------------------------

std::string g_log_csv, g_log_bin, g_table;

std::vector<std::string> lines_of(const std::string& s) {
  std::vector<std::string> v;
  std::istringstream in(s);
  for (std::string l; std::getline(in, l);) v.push_back(l);
  return v;
}
std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& l : v) s += l + "\n";
  return s;
}
std::vector<std::string> cells(const std::string& l) {
  std::vector<std::string> c;
  std::string x;
  std::istringstream in(l);
  while (std::getline(in, x, ',')) c.push_back(x);
  if (!l.empty() && l.back() == ',') c.push_back("");
  return c;
}
std::string uncells(const std::vector<std::string>& c) {
  std::string s;
  for (std::size_t i = 0; i < c.size(); ++i) s += (i ? "," : "") + c[i];
  return s;
}
std::size_t header_index(const std::vector<std::string>& L) {
  for (std::size_t i = 0; i < L.size(); ++i)
    if (!L[i].empty() && L[i][0] != '#') return i;
  return 0;
}
// Edits cell `col` (by header name) of data row `row` (0 = first data row).
std::string csv_edit(const std::string& col, std::size_t row, const std::string& value) {
  auto L = lines_of(g_log_csv);
  const std::size_t h = header_index(L);
  const auto names = cells(L[h]);
  const auto k = static_cast<std::size_t>(std::find(names.begin(), names.end(), col) - names.begin());
  auto c = cells(L[h + 1 + row]);
  c.at(k) = value;
  L[h + 1 + row] = uncells(c);
  return join(L);
}

struct Case {
  std::string file;    // what the user handed: "log CSV", "campaign JSON", ...
  std::string broken;  // how it is broken
  std::string input;   // the broken file's path (must appear in the message)
  std::string args;    // the command line (outputs go to OUT/)
  std::string says;    // a piece of the message naming the line, column or key
};

class MalformedInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    fs::remove_all(kWork);
    fs::create_directories(kWork + "/good");
    const std::string good = kWork + "/good/";
    g_log_csv = good + "log.csv";
    g_log_bin = good + "log.bin";
    const std::string sim = std::string(IMUFORGE_BIN) + " simulate --campaign " + ex("campaign-small.json") +
                            " --sensor " + ex("sensor-consumer.json") + " --rate 10 --max-duration 400 --quiet --out ";
    ASSERT_EQ(std::system((sim + g_log_csv).c_str()), 0);
    ASSERT_EQ(std::system((sim + g_log_bin).c_str()), 0);
    g_log_csv = slurp(g_log_csv);
    g_log_bin = slurp(g_log_bin);
    ASSERT_EQ(std::system((std::string(IMUFORGE_BIN) + " solve --log " + good + "log.bin --model " + ex("model-basic.json") +
                           " --out " + good + "cal.json --table " + good + "table.bin --serial 1 > /dev/null")
                              .c_str()),
              0);
    g_table = good + "table.bin";
  }
};

// Runs every case: exit 2, one line naming the file and the spot, OUT/ unchanged. Prints the table.
void check_all(const std::vector<Case>& cases) {
  int n = 0;
  for (const auto& c : cases) {
    const std::string out = kWork + "/out";
    fs::remove_all(out);
    fs::create_directories(out);
    put(out + "/already-here.txt", "an earlier result that a failed command must not touch\n");
    const auto before = snapshot(out);
    std::string args = c.args;
    for (std::string::size_type p; (p = args.find("OUT/")) != std::string::npos;) args.replace(p, 4, out + "/");
    const CliRun r = run(args);
    std::string line = r.err;
    if (!line.empty() && line.back() == '\n') line.pop_back();
    std::printf("| %-16s | %-44s | %d | %s\n", c.file.c_str(), c.broken.c_str(), r.code, line.c_str());
    EXPECT_EQ(r.code, 2) << c.file << " / " << c.broken << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.file << " / " << c.broken << ": " << r.err;
    EXPECT_NE(line.find(c.input), std::string::npos) << c.file << " / " << c.broken << ": message does not name " << c.input;
    EXPECT_NE(line.find(c.says), std::string::npos) << c.file << " / " << c.broken << ": message lacks '" << c.says << "'";
    EXPECT_EQ(snapshot(out), before) << c.file << " / " << c.broken << ": output directory changed";
    ++n;
  }
  std::printf("malformed-input cases: %d\n", n);
}

// Writes the broken file under the case directory and returns its path.
std::string bad(const std::string& name, const std::string& content) {
  const std::string p = kWork + "/in/" + name;
  fs::create_directories(kWork + "/in");
  put(p, content);
  return p;
}
std::string bad_sparse(const std::string& name, const std::string& head) {
  const std::string p = kWork + "/in/" + name;
  fs::create_directories(kWork + "/in");
  put_sparse(p, head, off_t{2} << 30);  // 2 GiB line
  return p;
}
std::string binary_junk() {
  std::string s = slurp(IMUFORGE_BIN).substr(0, 200000);  // an ELF file: NULs, no structure
  return s;
}
std::string json_edit(const std::string& file, const std::function<void(json&)>& f) {
  json j = json::parse(slurp(file));
  f(j);
  return j.dump(2);
}

// JSON files: the same breakages for each, through the command that reads it.
void json_cases(std::vector<Case>& v, const std::string& kind, const std::string& good, const std::string& cmd,
                const std::string& key_wrong_type, const std::string& key_missing, const std::string& number_path) {
  const std::string text = slurp(good);
  const std::string tag = kind.substr(0, kind.find(' '));
  auto add = [&](const std::string& broken, const std::string& path, const std::string& says) {
    std::string a = cmd;
    a.replace(a.find("@"), 1, path);
    v.push_back({kind, broken, path, a, says});
  };
  add("truncated (first half)", bad(tag + "-trunc.json", text.substr(0, text.size() / 2)), "malformed JSON");
  add("wrong type: \"" + key_wrong_type + "\" is a string",
      bad(tag + "-type.json", json_edit(good, [&](json& j) { j[key_wrong_type] = "oops"; })), key_wrong_type);
  add("missing key \"" + key_missing + "\"",
      bad(tag + "-missing.json", json_edit(good, [&](json& j) { j.erase(key_missing); })), key_missing);
  // JSON has no NaN/Inf: a writer that prints them makes a syntax error at that spot.
  {
    std::string t = text;
    const auto p = t.find(number_path);
    const auto colon = t.find(':', p);
    const auto end = t.find_first_of(",}\n", colon);
    t.replace(colon + 1, end - colon - 1, " NaN");
    add("NaN where a number goes (" + number_path + ")", bad(tag + "-nan.json", t), "malformed JSON");
    t.replace(t.find(" NaN"), 4, " Infinity");
    add("Infinity where a number goes", bad(tag + "-inf.json", t), "malformed JSON");
  }
  add("empty file", bad(tag + "-empty.json", ""), "empty");
  add("2 GiB file (sparse)", bad_sparse(tag + "-2g.json", "{\"a\": \""), "larger than");
  add("binary file", bad(tag + "-binary.json", binary_junk()), "malformed JSON");
}

}  // namespace

TEST_F(MalformedInput, Logs) {
  std::vector<Case> v;
  const std::string model = ex("model-basic.json");
  auto solve = [&](const std::string& p) { return "solve --log " + p + " --model " + model + " --out OUT/cal.json --table OUT/table.bin --serial 1"; };
  auto comp = [&](const std::string& p) { return "compensate --table " + g_table + " --in " + p + " --out OUT/comp.csv"; };
  auto conv = [&](const std::string& p) { return "convert --in " + p + " --out OUT/conv.bin"; };
  // Every broken log through each command that reads one: solve, compensate and convert (issue 16:
  // convert exits 2 on a bad input like every other command).
  auto both = [&](const std::string& file, const std::string& broken, const std::string& p, const std::string& says) {
    v.push_back({file, broken + " [solve]", p, solve(p), says});
    v.push_back({file, broken + " [compensate]", p, comp(p), says});
    v.push_back({file, broken + " [convert]", p, conv(p), says});
  };
  auto L = lines_of(g_log_csv);
  const std::size_t h = header_index(L);
  // truncated: the last row cut after its third cell
  {
    auto T = L;
    T.resize(h + 40);
    auto c = cells(T.back());
    c.resize(3);
    T.back() = uncells(c);
    both("log CSV", "truncated mid-row", bad("trunc.csv", join(T)), ":" + std::to_string(h + 40) + ":");
  }
  both("log CSV", "wrong type: raw count 'abc'", bad("type.csv", csv_edit("ax", 5, "abc")), "(ax)");
  both("log CSV", "wrong type: fractional count", bad("frac.csv", csv_edit("gz", 5, "12.5")), "(gz)");
  {
    auto T = L;
    auto c = cells(T[h]);
    c.erase(std::find(c.begin(), c.end(), "ay"));
    T[h] = uncells(c);
    both("log CSV", "missing column 'ay' in the header", bad("missing.csv", join(T)), "'ay'");
  }
  {
    auto T = L;
    T.erase(std::remove_if(T.begin(), T.end(), [](const std::string& l) { return l.rfind("# format_version", 0) == 0; }), T.end());
    both("log CSV", "missing metadata format_version", bad("nover.csv", join(T)), "format_version");
  }
  both("log CSV", "NaN time", bad("nan-t.csv", csv_edit("t_s", 7, "nan")), "(t_s)");
  both("log CSV", "Inf reference", bad("inf-ref.csv", csv_edit("f_ref_x", 7, "inf")), "(f_ref_x)");
  both("log CSV", "Inf temperature", bad("inf-temp.csv", csv_edit("temp_C", 7, "inf")), "temp_C");
  both("log CSV", "time goes backwards", bad("backwards.csv", csv_edit("t_s", 10, "0")), "back in time");
  {
    // A dwell appended again at the end (later times): the same segment twice.
    auto T = L;
    const auto names = cells(L[h]);
    const auto ks = static_cast<std::size_t>(std::find(names.begin(), names.end(), "segment") - names.begin());
    const auto kt = static_cast<std::size_t>(std::find(names.begin(), names.end(), "t_s") - names.begin());
    double t_last = std::stod(cells(T.back())[kt]);
    for (std::size_t i = h + 1; i < L.size(); ++i) {
      auto c = cells(L[i]);
      if (c[ks] != "0") continue;
      t_last += 0.05;
      c[kt] = std::to_string(t_last);
      T.push_back(uncells(c));
    }
    both("log CSV", "duplicate segment (segment 0 again at the end)", bad("dupseg.csv", join(T)), "segment 0");
  }
  {
    std::vector<std::string> head(L.begin(), L.begin() + static_cast<long>(h) + 1);
    both("log CSV", "a 2 GiB line (sparse file)", bad_sparse("2g.csv", join(head)), "longer than 1 MiB");
  }
  both("log CSV", "empty file", bad("empty.csv", ""), "no header");
  both("log CSV", "binary file given as a CSV log", bad("binary.csv", binary_junk()), ":");
  // Binary encoding.
  {
    const std::string b = g_log_bin;
    both("log binary", "truncated mid-record", bad("trunc.bin", b.substr(0, b.size() - 100)), "truncated record");
    both("log binary", "header truncated", bad("hdr.bin", b.substr(0, 20)), "header truncated");
    std::string v2 = b;
    v2[8] = 2;
    both("log binary", "unknown version", bad("ver.bin", v2), "version");
    // NaN time in the first record: the data start at file size − rows × 152 (rows from the header).
    std::string nan_t = b;
    std::uint64_t declared = 0;
    std::memcpy(&declared, b.data() + 16, 8);
    const std::size_t data_off = b.size() - declared * 152;
    const double nan = std::nan("");
    std::memcpy(&nan_t[data_off], &nan, 8);
    both("log binary", "NaN time (record 0)", bad("nan.bin", nan_t), "record 0");
    std::string back = b;
    const double zero = 0.0;
    std::memcpy(&back[data_off + 5 * 152], &zero, 8);
    both("log binary", "time goes backwards (record 5)", bad("back.bin", back), "back in time");
    std::string flags = b;
    flags[data_off + 3 * 152 + 12] = 0x7f;
    both("log binary", "corrupt flag bits (record 3)", bad("flags.bin", flags), "record 3");
  }
  check_all(v);
}

TEST_F(MalformedInput, Imports) {
  std::vector<Case> v;
  auto mpu = [&](const std::string& p) { return "import --format mpu6050-csv --in " + p + " --out OUT/imp.bin"; };
  const std::string good = "Fs,100\nax,ay,az,gx,gy,gz\n1,2,16384,4,5,6\n1,2,16383,4,5,7\n";
  auto add = [&](const std::string& broken, const std::string& content, const std::string& says) {
    const std::string p = bad("mpu-" + std::to_string(v.size()) + ".csv", content);
    v.push_back({"mpu6050 CSV", broken, p, mpu(p), says});
  };
  add("truncated mid-row", good + "1,2,16", ":5:");
  add("wrong type: 'x' count", "Fs,100\nax,ay,az,gx,gy,gz\n1,2,x,4,5,6\n", "column 3");
  add("count out of int16 range", "Fs,100\nax,ay,az,gx,gy,gz\n1,2,70000,4,5,6\n", "column 3");
  add("missing header", "Fs,100\n1,2,3,4,5,6\n", ":2:");
  add("columns out of order (gx before ax)", "Fs,100\ngx,ay,az,ax,gy,gz\n1,2,3,4,5,6\n", "header column 1");
  add("NaN count", "Fs,100\nax,ay,az,gx,gy,gz\n1,nan,3,4,5,6\n", "column 2");
  add("Inf count", "Fs,100\nax,ay,az,gx,gy,gz\n1,2,inf,4,5,6\n", "column 3");
  add("Inf sample rate", "Fs,inf\nax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n", "Fs");
  add("empty file", "", "no header");
  add("binary file given as CSV", binary_junk(), ":");
  {
    const std::string p = bad_sparse("mpu-2g.csv", "Fs,100\nax,ay,az,gx,gy,gz\n");
    v.push_back({"mpu6050 CSV", "a 2 GiB line (sparse file)", p, mpu(p), "longer than 1 MiB"});
  }
  // xsens-imutk: two files with identical timestamps.
  const std::string acc = "0.00 32768 32900 46000\n0.01 32770 32901 45998\n0.02 32769 32899 46001\n";
  const std::string gyr = "0.00 32768 32768 32770\n0.01 32767 32769 32771\n0.02 32768 32768 32769\n";
  const std::string good_gyr = bad("xs-gyr.txt", gyr);
  auto xs = [&](const std::string& broken, const std::string& a, const std::string& says) {
    const std::string p = bad("xs-" + std::to_string(v.size()) + ".txt", a);
    v.push_back({"xsens-imutk", broken, p, "import --format xsens-imutk --in " + p + " --in-gyro " + good_gyr + " --out OUT/imp.csv", says});
  };
  xs("truncated mid-row", acc + "0.03 32768", ":4:");
  xs("wrong type", "0.00 32768 abc 46000\n0.01 32770 32901 45998\n0.02 32769 32899 46001\n", "column 3");
  xs("time goes backwards", "0.00 32768 32900 46000\n0.01 32770 32901 45998\n0.005 32769 32899 46001\n", ":3");
  xs("duplicate time", "0.00 32768 32900 46000\n0.01 32770 32901 45998\n0.01 32769 32899 46001\n", ":");
  xs("NaN time", "nan 32768 32900 46000\n0.01 32770 32901 45998\n0.02 32769 32899 46001\n", "column 1");
  xs("Inf count", "0.00 32768 inf 46000\n0.01 32770 32901 45998\n0.02 32769 32899 46001\n", "column 3");
  xs("empty file", "", "no samples");
  xs("binary file", binary_junk(), ":");
  {
    const std::string p = bad_sparse("xs-2g.txt", "");
    v.push_back({"xsens-imutk", "a 2 GiB line (sparse file)", p,
                 "import --format xsens-imutk --in " + p + " --in-gyro " + good_gyr + " --out OUT/imp.csv", "longer than 1 MiB"});
  }
  check_all(v);
}

TEST_F(MalformedInput, JsonFiles) {
  std::vector<Case> v;
  json_cases(v, "campaign JSON", ex("campaign-small.json"),
             "simulate --campaign @ --sensor " + ex("sensor-consumer.json") + " --out OUT/sim.bin", "phases", "phases",
             "\"sample_rate_hz\"");
  json_cases(v, "sensor JSON", ex("sensor-consumer.json"),
             "simulate --campaign " + ex("campaign-small.json") + " --sensor @ --out OUT/sim.bin", "accel", "gyro",
             "\"T_ref_C\"");
  json_cases(v, "model JSON", ex("model-basic.json"),
             "solve --log " + kWork + "/good/log.bin --model @ --out OUT/cal.json", "effects", "effects", "\"T_ref_C\"");
  // The station names its model relative to itself: the copy points at the example's by absolute path.
  const std::string station = kWork + "/good/station.json";
  put(station, json_edit(ex("station.json"), [](json& j) { j["model"] = ex(j["model"].get<std::string>()); }));
  json_cases(v, "station JSON", station, "run --station @ --campaign " + ex("campaign-small.json") +
                                             " --serial 1 --out OUT/run --quiet",
             "verification", "fixtures", "\"time_scale\"");
  json_cases(v, "register map", map_file("imuforge-table.json"),
             "bench-sim --no-tcp --duration 0.1 --table-map @", "points", "points", "\"axes\"");
  json_cases(v, "cal.json", kWork + "/good/cal.json",
             "diagnose --log " + kWork + "/good/log.bin --model @ --out OUT/diag", "model", "model", "\"T_ref_C\"");
  check_all(v);
}

TEST_F(MalformedInput, CoefficientTable) {
  std::vector<Case> v;
  const std::string t = slurp(g_table);
  auto add = [&](const std::string& broken, const std::string& path, const std::string& says) {
    v.push_back({"coefficient table", broken, path,
                 "compensate --table " + path + " --in " + kWork + "/good/log.bin --out OUT/comp.csv", says});
  };
  add("truncated", bad("trunc.table", t.substr(0, t.size() / 2)), "invalid coefficient table");
  std::string crc = t;
  crc[crc.size() / 2] = static_cast<char>(crc[crc.size() / 2] ^ 0x5a);
  add("a corrupted byte (CRC)", bad("crc.table", crc), "invalid coefficient table");
  add("empty file", bad("empty.table", ""), "invalid coefficient table");
  add("binary file (not a table)", bad("elf.table", binary_junk()), "invalid coefficient table");
  add("2 GiB file (sparse)", bad_sparse("2g.table", t), "invalid coefficient table");
  check_all(v);
}

TEST_F(MalformedInput, Journal) {
  // `run --resume DIR` reads DIR/journal.log first.
  std::vector<Case> v;
  const std::string station = ex("station.json");
  auto entry = [](const json& e) {
    // The journal line format (docs/eol.md): the CRC is checked, so a good line needs the right one.
    const std::string b = e.dump();
    char h[9];
    std::snprintf(h, sizeof h, "%08x", imuforge::fw::crc32(reinterpret_cast<const std::uint8_t*>(b.data()), b.size()));
    return "J1 " + std::string(h) + " " + b + "\n";
  };
  const std::string start = entry({{"type", "run_start"}, {"serial", "1"}, {"station_path", station}, {"campaign_path", ex("campaign-small.json")}});
  const std::string seg = entry({{"type", "plateau_settled"}, {"phase", 0}, {"temp_C", 25.0}, {"air_C", 25.0}, {"t_s", 1.0}});
  // Journal cases need the journal inside OUT/, which check_all recreates: run them here directly.
  struct J {
    std::string broken, content, says;
    bool sparse;
  };
  std::string corrupt_mid = start + seg;
  corrupt_mid[start.size() + 5] ^= 1;  // CRC of line 2 no longer matches
  const std::vector<J> js = {
      {"corrupt line (bad CRC) before the last", corrupt_mid + seg, "line 2", false},
      {"truncated to a torn first line", start.substr(0, 30), "line 1", false},
      {"empty file", "", "line 1", false},
      {"wrong type: run_start.station_path is a number", entry({{"type", "run_start"}, {"station_path", 5}}) + seg, "station_path", false},
      {"missing key \"type\"", entry({{"serial", "1"}}) + seg, "line 1", false},
      {"binary file", binary_junk() + "\n" + seg, "line 1", false},
      {"2 GiB line (sparse file)", start, "larger than", true},
  };
  int n = 0;
  for (const auto& j : js) {
    const std::string out = kWork + "/out";
    fs::remove_all(out);
    fs::create_directories(out + "/run");
    const std::string jp = out + "/run/journal.log";
    if (j.sparse) {
      put_sparse(jp, j.content, off_t{2} << 30);
    } else {
      put(jp, j.content);
    }
    const auto before = snapshot(out);
    const CliRun r = run("run --resume " + out + "/run --quiet");
    std::string line = r.err;
    if (!line.empty() && line.back() == '\n') line.pop_back();
    std::printf("| %-16s | %-44s | %d | %s\n", "run journal", j.broken.c_str(), r.code, line.c_str());
    EXPECT_EQ(r.code, 2) << j.broken << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << j.broken << ": " << r.err;
    EXPECT_NE(line.find(jp), std::string::npos) << j.broken << ": " << r.err;
    EXPECT_NE(line.find(j.says), std::string::npos) << j.broken << ": " << r.err;
    EXPECT_EQ(snapshot(out), before) << j.broken;
    ++n;
  }
  std::printf("malformed-input cases: %d\n", n);
}

// Log columns are matched by name (docs/formats.md): a header in another order, with its rows in that
// order, is the same log, read the same. This is the one "out of order" that is not an error.
TEST_F(MalformedInput, LogColumnsInAnotherOrderReadTheSame) {
  auto L = lines_of(g_log_csv);
  const std::size_t h = header_index(L);
  for (std::size_t i = h; i < L.size(); ++i) {
    auto c = cells(L[i]);
    std::reverse(c.begin(), c.end());
    L[i] = uncells(c);
  }
  const std::string p = bad("reversed.csv", join(L));
  fs::create_directories(kWork + "/out2");
  put(kWork + "/good/log-again.csv", g_log_csv);
  const std::string c1 = "compensate --table " + g_table + " --in " + kWork + "/good/log-again.csv --out " + kWork + "/out2/a.csv";
  const std::string c2 = "compensate --table " + g_table + " --in " + p + " --out " + kWork + "/out2/b.csv";
  ASSERT_EQ(run(c1).code, 0);
  ASSERT_EQ(run(c2).code, 0);
  EXPECT_EQ(slurp(kWork + "/out2/a.csv"), slurp(kWork + "/out2/b.csv"));
}
}  // namespace cli_malformed_input_test
