// libFuzzer: the EOL run journal (host/eol/journal.cpp) as `run --resume` reads it. A journal that reads
// gives typed entries; re-encoded, they read back the same; the valid prefix is inside the file.
#include "host/eol/journal.h"
#include "tests/fuzz/host/fuzz_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge::eol;
  JournalContents c;
  try {
    c = read_journal(fuzzio::write_file("journal.log", data, size));
  } catch (const std::exception& e) {
    fuzzio::check_refusal(e);
    return 0;
  }
  FUZZ_CHECK(c.valid_bytes <= size);
  FUZZ_CHECK(c.torn_tail || c.valid_bytes == size);
  std::string again;
  for (const auto& e : c.entries) {
    FUZZ_CHECK(e.is_object() && e.contains("type") && e["type"].is_string());
    again += journal_line(e);
  }
  const std::string p = fuzzio::scratch("journal2.log");
  std::FILE* f = std::fopen(p.c_str(), "wb");
  std::fwrite(again.data(), 1, again.size(), f);
  std::fclose(f);
  const JournalContents c2 = read_journal(p);
  FUZZ_CHECK(!c2.torn_tail && c2.entries == c.entries);
  return 0;
}
