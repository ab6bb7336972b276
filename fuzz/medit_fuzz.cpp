// libFuzzer target: parse_medit on arbitrary bytes (see fuzz_common.hpp).
#include "fuzz_common.hpp"
#include "io/common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetopt;
  TetMesh m;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const Status st = parse_medit(in, "fuzz", m);
  {
    // The reader's parallel fast path (every section, 13-byte chunks, one
    // thread) must give the serial result: the same mesh or the same error.
    TetMesh f;
    const Status sf = detail::parse_medit_tuned(in, "fuzz", f, 1, 1, 13);
    if (sf.ok() != st.ok() || sf.message != st.message || sf.line != st.line)
      tetopt_fuzz::die("fast path disagrees with the serial reader:", st.message + " | " + sf.message);
    if (st.ok()) tetopt_fuzz::same_or_die(m, f, "medit fast path");
  }
  if (!st) return tetopt_fuzz::refused("reader refused:", st.message);
  if (!tetopt_fuzz::finish_read(m, Format::Medit)) return 0;
  tetopt_fuzz::check_topology(m);
  std::string out;
  if (Status s = format_medit(m, out); !s) tetopt_fuzz::die("writer refused an accepted mesh:", s.message);
  TetMesh back;
  if (Status s = parse_medit(out, "fuzz-rt", back); !s) tetopt_fuzz::die("re-read of written mesh failed:", s.message);
  if (!tetopt_fuzz::finish_read(back, Format::Medit)) tetopt_fuzz::die("re-read mesh rejected");
  tetopt_fuzz::same_or_die(m, back, "medit");
  return 0;
}
