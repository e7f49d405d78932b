// Journal: round trip, torn-last-line tolerance, corruption before the end is refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "host/eol/journal.h"
#include "host/records/record.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_journal {

using namespace imuforge::eol;
namespace fs = std::filesystem;

namespace {
fs::path tmpdir() {
  auto d = fs::temp_directory_path() / ("imuforge-journal-" + imuforge::records::new_record_id());
  fs::create_directories(d);
  return d;
}
void append_raw(const fs::path& p, const std::string& bytes) {
  std::ofstream f(p, std::ios::binary | std::ios::app);
  f << bytes;
}
}  // namespace

TEST(Journal, RoundTrip) {
  auto d = tmpdir();
  auto p = (d / "journal.log").string();
  {
    auto j = Journal::create(p);
    j.append({{"type", "run_start"}, {"serial", "SN\n1"}});
    j.append({{"type", "segment_done"}, {"key", "p0s0"}, {"v", 1.5}});
  }
  EXPECT_THROW(Journal::create(p), JournalError) << "create must not overwrite a run";
  auto c = read_journal(p);
  ASSERT_EQ(c.entries.size(), 2u);
  EXPECT_FALSE(c.torn_tail);
  EXPECT_EQ(c.entries[0]["serial"], "SN\n1");
  EXPECT_EQ(c.entries[1]["v"], 1.5);
  fs::remove_all(d);
}

TEST(Journal, TornLastLineIsDroppedAndCutOnAppend) {
  auto d = tmpdir();
  auto p = (d / "journal.log").string();
  {
    auto j = Journal::create(p);
    j.append({{"type", "run_start"}});
    j.append({{"type", "segment_done"}, {"key", "p0s0"}});
  }
  // A crash in the middle of the third append: half a line, no newline.
  std::string full = journal_line({{"type", "segment_done"}, {"key", "p0s1"}});
  append_raw(p, full.substr(0, full.size() / 2));
  auto c = read_journal(p);
  EXPECT_TRUE(c.torn_tail);
  ASSERT_EQ(c.entries.size(), 2u);
  EXPECT_EQ(c.entries[1]["key"], "p0s0");
  {
    JournalContents c2;
    auto j = Journal::open_existing(p, &c2);
    EXPECT_TRUE(c2.torn_tail);
    j.append({{"type", "segment_done"}, {"key", "p0s1"}});
  }
  auto c3 = read_journal(p);
  EXPECT_FALSE(c3.torn_tail);
  ASSERT_EQ(c3.entries.size(), 3u);
  EXPECT_EQ(c3.entries[2]["key"], "p0s1");
  fs::remove_all(d);
}

TEST(Journal, TornLastLineWithNewlineButBadChecksum) {
  auto d = tmpdir();
  auto p = (d / "journal.log").string();
  { Journal::create(p).append({{"type", "run_start"}}); }
  std::string l = journal_line({{"type", "x"}});
  l[5] = l[5] == '0' ? '1' : '0';  // flip a checksum digit
  append_raw(p, l);
  auto c = read_journal(p);
  EXPECT_TRUE(c.torn_tail);
  EXPECT_EQ(c.entries.size(), 1u);
  fs::remove_all(d);
}

TEST(Journal, CorruptionBeforeTheLastLineIsAnError) {
  auto d = tmpdir();
  auto p = (d / "journal.log").string();
  {
    auto j = Journal::create(p);
    j.append({{"type", "run_start"}});
    j.append({{"type", "segment_done"}, {"key", "p0s0"}});
    j.append({{"type", "segment_done"}, {"key", "p0s1"}});
  }
  // Flip one byte inside the second line's JSON.
  std::string data;
  {
    std::ifstream f(p, std::ios::binary);
    data.assign(std::istreambuf_iterator<char>(f), {});
  }
  auto second = data.find('\n') + 1;
  auto pos = data.find("p0s0", second);
  ASSERT_NE(pos, std::string::npos);
  data[pos + 3] = '9';
  {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    f << data;
  }
  try {
    read_journal(p);
    FAIL() << "expected JournalError";
  } catch (const JournalError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  fs::remove_all(d);
}

TEST(Journal, GarbageFileIsAnError) {
  auto d = tmpdir();
  auto p = (d / "journal.log").string();
  append_raw(p, "hello\nworld\n");
  EXPECT_THROW(read_journal(p), JournalError);
  EXPECT_THROW(read_journal((d / "missing.log").string()), JournalError);
  fs::remove_all(d);
}
}  // namespace eol_test_journal
