// Format dispatch, whole-file reading and atomic writing (see io.hpp).
#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sys/mman.h>
#include <sys/stat.h>
#include <fcntl.h>
#include <fstream>
#include <new>
#include <stdexcept>
#include <future>
#include <random>
#include <sstream>
#include <unistd.h>
#include <utility>
#include <vector>

#include "tetopt/io.hpp"

#include "detail/parallel.hpp"
#include "io/common.hpp"

namespace tetopt {

namespace {
bool ends_with(const std::string& s, const char* suf) {
  const std::string x(suf);
  if (s.size() < x.size()) return false;
  for (size_t i = 0; i < x.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - x.size() + i])) != x[i]) return false;
  return true;
}
std::string stem(const std::string& p) {
  const size_t dot = p.find_last_of('.');
  const size_t slash = p.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return p;
  return p.substr(0, dot);
}
// A read-only memory map of a whole file: the parsers read the page cache
// directly, with no zero-filled buffer and no copy (large files load faster).
class MappedFile {
 public:
  ~MappedFile() {
    if (ptr_ && ptr_ != MAP_FAILED) ::munmap(ptr_, size_);
  }
  bool open(const std::string& path) {
    // O_NONBLOCK: opening a FIFO (or a device) must not wait for a writer;
    // fstat then turns anything but a regular file away.
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return false;
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size <= 0) {
      ::close(fd);
      return false;
    }
    size_ = static_cast<size_t>(st.st_size);
    ptr_ = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    ::close(fd);
    if (ptr_ == MAP_FAILED) { ptr_ = nullptr; return false; }
    ::madvise(ptr_, size_, MADV_SEQUENTIAL);
    return true;
  }
  std::string_view view() const { return {static_cast<const char*>(ptr_), size_}; }

 private:
  void* ptr_ = nullptr;
  size_t size_ = 0;
};
}  // namespace

namespace {
bool is_dir(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}
bool is_file(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}
// The path without trailing slashes ("/" stays).
std::string no_trailing_slash(std::string p) {
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  return p;
}
bool names_polymesh(const std::string& path) {
  const std::string p = no_trailing_slash(path);
  return p == "polyMesh" || (p.size() > 9 && p.compare(p.size() - 9, 9, "/polyMesh") == 0);
}
}  // namespace

std::string openfoam_dir(const std::string& path) {
  const std::string p = no_trailing_slash(path);
  if (is_dir(p) && is_file(p + "/owner")) return p;
  if (is_dir(p) && is_file(p + "/constant/polyMesh/owner")) return p + "/constant/polyMesh";
  if (names_polymesh(p)) return p;
  return {};
}

Format format_from_path(const std::string& path) {
  if (names_polymesh(path) || (is_dir(path) && !openfoam_dir(path).empty())) return Format::OpenFoam;
  if (ends_with(path, ".meshb")) return Format::MeditBinary;
  if (ends_with(path, ".mesh")) return Format::Medit;
  if (ends_with(path, ".msh")) return Format::Gmsh;
  if (ends_with(path, ".vtk")) return Format::Vtk;
  if (ends_with(path, ".vtu")) return Format::Vtu;
  if (ends_with(path, ".node") || ends_with(path, ".ele")) return Format::TetGen;
  if (ends_with(path, ".inp")) return Format::Abaqus;
  if (ends_with(path, ".cgns")) return Format::Cgns;
  if (ends_with(path, ".exo") || ends_with(path, ".e") || ends_with(path, ".ex2")) return Format::Exodus;
  return Format::Unknown;
}

namespace {
// A file name as messages show it (control characters escaped: one line).
std::string shown(const std::string& path) { return detail::escaped_name(path); }
}  // namespace

Status read_file_bytes(const std::string& path, std::string& out) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return Status::error(ErrorCode::Io, shown(path) + ": no such file");
  if (!S_ISREG(st.st_mode)) return Status::error(ErrorCode::Io, shown(path) + ": not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::error(ErrorCode::Io, shown(path) + ": cannot open for reading");
  in.seekg(0, std::ios::end);
  const std::streamoff n = in.tellg();
  if (n < 0) return Status::error(ErrorCode::Io, shown(path) + ": cannot determine the file size");
  in.seekg(0, std::ios::beg);
  out.resize(static_cast<size_t>(n));
  if (n > 0 && !in.read(out.data(), n)) return Status::error(ErrorCode::Io, shown(path) + ": read failed");
  return Status::success();
}

namespace {
// The temporary files being written, for remove_pending_temporaries (a
// signal handler may read them at any moment: a slot's path is complete
// whenever `ready` is set).  A path too long for a slot is not listed.
struct PendingTemp {
  std::atomic<bool> taken{false}, ready{false};
  char path[4096];
};
PendingTemp g_pending[16];

// Lists tmp while it exists (from before its creation to its rename or
// removal); unlisting it is the destructor's.
class ListedTemp {
 public:
  explicit ListedTemp(const std::string& tmp) {
    if (tmp.size() >= sizeof(PendingTemp::path)) return;
    for (PendingTemp& p : g_pending)
      if (!p.taken.exchange(true)) {
        std::copy(tmp.begin(), tmp.end(), p.path);
        p.path[tmp.size()] = '\0';
        p.ready.store(true);
        slot_ = &p;
        return;
      }
  }
  ~ListedTemp() {
    if (!slot_) return;
    slot_->ready.store(false);
    slot_->taken.store(false);
  }
  ListedTemp(ListedTemp&& o) noexcept : slot_(o.slot_) { o.slot_ = nullptr; }
  ListedTemp(const ListedTemp&) = delete;
  ListedTemp& operator=(const ListedTemp&) = delete;

 private:
  PendingTemp* slot_ = nullptr;
};

// The system's reason for an errno value ("File too large").
std::string reason(int err) { return std::strerror(err); }

// The folder of a path ("." when it names none).
std::string folder_of(const std::string& p) {
  const size_t slash = p.rfind('/');
  return slash == std::string::npos ? "." : slash == 0 ? "/" : p.substr(0, slash);
}

// A new name beside target: TARGET.tmp-PID-N.  A target whose name leaves
// no room for the suffix in one folder entry (NAME_MAX, 255 bytes on most
// file systems) gives its name cut short before the suffix: a 250-byte name
// is a valid output.
std::string temp_name(const std::string& target) {
  std::random_device rd;
  const std::string suffix = ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(rd() % 100000);
  const size_t slash = target.rfind('/'), base = slash == std::string::npos ? 0 : slash + 1;
  size_t keep = target.size() - base;
  if (keep + suffix.size() > 64) {
    const long max = ::pathconf(folder_of(target).c_str(), _PC_NAME_MAX);
    const size_t limit = max > 0 ? static_cast<size_t>(max) : 255;
    if (keep + suffix.size() > limit) keep = limit > suffix.size() ? limit - suffix.size() : 0;
  }
  return target.substr(0, base + keep) + suffix;
}

// Writes all of bytes; 0, or the errno of the failure (EFBIG past a file
// size limit once SIGXFSZ is ignored, ENOSPC, EIO).  The value is returned,
// not left in errno, since the Medit writer calls this on a helper thread.
int write_all(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t w = ::write(fd, bytes.data(), bytes.size());
    if (w < 0 && errno == EINTR) continue;
    if (w < 0) return errno;
    if (w == 0) return EIO;
    bytes.remove_prefix(static_cast<size_t>(w));
  }
  return 0;
}

Status write_failed(int err) { return Status::error(ErrorCode::Io, "write failed: " + reason(err)); }

// The file a write to `path` replaces: path with its symbolic links followed
// (at most 40, Linux's own limit), into `target`.  A link that points
// nowhere gives the path it points to, which the write creates; a path that
// names nothing is its own target (its folder is checked later).  A link
// loop, a name too long, a folder that cannot be searched is an error with
// the system's reason ("Too many levels of symbolic links", "File name too
// long"): before, a loop's last link was replaced by a regular file.
Status follow_links(const std::string& path, std::string& target) {
  std::string p = path;
  for (int hop = 0;; ++hop) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0) {
      const int err = errno;
      if (err == ENOENT) break;
      return Status::error(ErrorCode::Io, shown(path) + ": " + reason(err));
    }
    if (!S_ISLNK(st.st_mode)) break;
    if (hop == 40) return Status::error(ErrorCode::Io, shown(path) + ": " + reason(ELOOP));
    std::string to(static_cast<size_t>(st.st_size > 0 ? st.st_size : 4096) + 1, '\0');
    const ssize_t n = ::readlink(p.c_str(), to.data(), to.size());
    if (n < 0) {
      const int err = errno;
      return Status::error(ErrorCode::Io, shown(path) + ": " + reason(err));
    }
    if (n == 0) return Status::error(ErrorCode::Io, shown(path) + ": " + reason(ENOENT));
    to.resize(static_cast<size_t>(n));
    if (to[0] != '/') {
      const size_t slash = p.rfind('/');
      if (slash != std::string::npos) to = p.substr(0, slash + 1) + to;
    }
    p = to;
  }
  target = p;
  return Status::success();
}

// check_output_path for one file, on its target (links followed): *old gets
// the target's stat and *exists whether there is one.  probe: also create
// (and remove) a file in its folder; a writer skips that, since creating its
// temporary file is the same test.
Status check_one_output(const std::string& path, const std::string& target, bool probe, struct stat* old = nullptr,
                        bool* exists = nullptr) {
  struct stat st {};
  const bool there = ::stat(target.c_str(), &st) == 0;
  const int err = there ? 0 : errno;
  if (!there && err != ENOENT) return Status::error(ErrorCode::Io, shown(path) + ": " + reason(err));
  if (there) {
    if (S_ISDIR(st.st_mode)) return Status::error(ErrorCode::Io, shown(path) + ": is a folder, not a file");
    if (!S_ISREG(st.st_mode))
      return Status::error(ErrorCode::Io, shown(path) + ": not a regular file (a device, FIFO or socket); tetopt "
                                                        "writes a temporary file and renames it into place, which "
                                                        "would replace it");
  }
  if (old) *old = st;
  if (exists) *exists = there;
  const std::string dir = folder_of(target);
  struct stat dst {};
  const int dir_err = ::stat(dir.c_str(), &dst) == 0 ? (S_ISDIR(dst.st_mode) ? 0 : ENOTDIR) : errno;
  if (dir_err == ENOENT || dir_err == ENOTDIR)
    return Status::error(ErrorCode::Io, shown(path) + ": no such folder '" + shown(dir) + "'");
  if (dir_err != 0) return Status::error(ErrorCode::Io, shown(path) + ": folder '" + shown(dir) + "': " + reason(dir_err));
  if (!probe) return Status::success();
  // Creating a file there is the only sure test (access() says yes to root
  // in a read-only or pseudo file system such as /sys).
  const std::string tmp = temp_name(target);
  const ListedTemp listed(tmp);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    const int open_err = errno;
    return Status::error(ErrorCode::Io, shown(path) + ": cannot create files in folder '" + shown(dir) + "': " +
                                            reason(open_err));
  }
  ::close(fd);
  ::unlink(tmp.c_str());
  return Status::success();
}

// One output being written: its temporary file beside its target (links
// followed), listed for remove_pending_temporaries from before it exists,
// and removed by the destructor unless it was renamed into place, so that
// every way out (an error, a bad_alloc while formatting) leaves nothing.
struct TempFile {
  std::string path, target, tmp;  // as given (for messages), the file replaced, the temporary
  std::vector<ListedTemp> listed;  // zero or one
  bool exists = false;             // the temporary is there and ours
  TempFile() = default;
  TempFile(TempFile&& o) noexcept
      : path(std::move(o.path)), target(std::move(o.target)), tmp(std::move(o.tmp)), listed(std::move(o.listed)),
        exists(o.exists) {
    o.exists = false;
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  TempFile& operator=(TempFile&&) = delete;
  ~TempFile() {
    if (exists) ::unlink(tmp.c_str());
  }
};

// Closes a descriptor on every way out.
struct FdGuard {
  int fd = -1;
  ~FdGuard() {
    if (fd >= 0) ::close(fd);
  }
  int release() { return std::exchange(fd, -1); }
};

// Writes the temporary file of `path` with body(fd), which returns
// write_failed(err) or a format error.  A rewritten file keeps the mode of
// the one it replaces, and its owner and group where the system permits
// (fchown: root may give any; a user the group of one of its groups); a new
// file gets 0666 less the umask, as open(2) gives it.  The temporary is
// created 0600 when the target exists, so the new bytes are never readable
// by more than the old ones, and given the old mode after they are written
// (a write clears setuid and setgid bits).  It is fsynced before it is
// closed: renamed into place afterwards, it is whole on disk, even after a
// crash of the machine.
template <class Body>
Status write_temp(const std::string& path, const Body& body, TempFile& t) {
  t.path = path;
  if (Status s = follow_links(path, t.target); !s) return s;
  struct stat old {};
  bool replaces = false;
  if (Status s = check_one_output(path, t.target, false, &old, &replaces); !s) return s;
  int fd = -1, err = 0;
  for (int attempt = 0; attempt < 3 && fd < 0; ++attempt) {  // another name on the rare clash of two
    t.tmp = temp_name(t.target);
    t.listed.clear();
    t.listed.emplace_back(t.tmp);
    fd = ::open(t.tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, replaces ? 0600 : 0666);
    err = fd < 0 ? errno : 0;
    if (err != EEXIST) break;
  }
  if (fd < 0)
    return Status::error(ErrorCode::Io, shown(path) + ": cannot create a file in folder '" +
                                            shown(folder_of(t.target)) + "': " + reason(err));
  t.exists = true;
  FdGuard guard{fd};
  Status s = body(fd);
  if (s && replaces) {
    if (::fchown(fd, old.st_uid, old.st_gid) != 0) {
      const int ignored = ::fchown(fd, static_cast<uid_t>(-1), old.st_gid);  // EPERM: not ours to give
      (void)ignored;
    }
    const int ignored = ::fchmod(fd, old.st_mode & 07777);  // fails only where modes do not exist (FAT)
    (void)ignored;
  }
  if (s && ::fsync(fd) != 0) s = write_failed(errno);
  if (::close(guard.release()) != 0 && s) s = write_failed(errno);
  if (!s) return Status::error(s.code, shown(path) + ": " + s.message);
  return Status::success();
}

// fsyncs a folder after a rename into it, so the new entry is on disk too.
// Best effort: some file systems refuse fsync on a folder (EINVAL), and the
// file is in place either way.
void sync_folder(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  const int ignored = ::fsync(fd);
  (void)ignored;
  ::close(fd);
}

// Writes paths[k] with body(k, fd), all or none: every file goes to its
// temporary file in its target's folder (see write_temp) before any is
// renamed into place, so a full disk, a file size limit or an unwritable
// name leaves none of the new files (a TetGen .node/.ele/.face set) and the
// old ones as they were; then the folders are fsynced.  A symbolic link is
// followed (the file it names is replaced, the link stays), and a target
// that is not a regular file is refused before anything is written.
template <class Body>
Status write_set(const std::vector<std::string>& paths, const Body& body) {
  std::vector<TempFile> temps;  // their destructors remove what was not renamed
  temps.reserve(paths.size());
  for (size_t k = 0; k < paths.size(); ++k) {
    temps.emplace_back();
    if (Status s = write_temp(paths[k], [&](int fd) { return body(k, fd); }, temps.back()); !s) return s;
  }
  std::vector<std::string> folders;
  for (TempFile& t : temps) {
    if (std::rename(t.tmp.c_str(), t.target.c_str()) != 0) {
      const int err = errno;
      return Status::error(ErrorCode::Io, shown(t.path) + ": cannot rename the temporary file into place: " +
                                              reason(err));
    }
    t.exists = false;
    const std::string dir = folder_of(t.target);
    if (std::find(folders.begin(), folders.end(), dir) == folders.end()) folders.push_back(dir);
  }
  for (const std::string& dir : folders) sync_folder(dir);
  return Status::success();
}

Status write_files_atomic(const std::vector<std::pair<std::string, std::string_view>>& files) {
  std::vector<std::string> paths;
  for (const auto& f : files) paths.push_back(f.first);
  return write_set(paths, [&](size_t k, int fd) {
    const int err = write_all(fd, files[k].second);
    return err ? write_failed(err) : Status::success();
  });
}

// The Medit text goes to the temporary file in pieces of about 4 MiB while
// the rest is formatted, instead of as one string of the whole file (the
// demo impeller's is 16 MB: a third of the process's peak memory, and its
// first touch).  With more than one thread each piece is written by a helper
// thread while the next one is formatted: the kernel's copy into the page
// cache (0.08 s for the impeller on this project's VM) then overlaps the
// formatting.  Same bytes as format_medit into one string.
Status write_medit_streamed(const std::string& path, const TetMesh& m, int threads) {
  return write_set({path}, [&](size_t, int fd) {
    const bool helper = detail::resolve_threads(threads) > 1;
    int err = 0;        // the first write's failure
    std::string piece;  // the piece being written; its buffer goes back to the formatter
    std::future<int> pending;
    auto wait = [&] {
      if (pending.valid()) {
        const int e = pending.get();
        if (!err) err = e;
      }
    };
    const TextFlush flush = [&](std::string& out) {
      wait();
      std::swap(out, piece);
      if (err) return;
      if (helper) pending = std::async(std::launch::async, [fd, &piece] { return write_all(fd, piece); });
      else err = write_all(fd, piece);
    };
    std::string out;
    const Status s = format_medit(m, out, threads, flush);
    wait();
    if (!s) return s;
    if (!err) err = write_all(fd, out);
    return err ? write_failed(err) : Status::success();
  });
}
}  // namespace

std::vector<std::string> mesh_files(const std::string& path) {
  if (format_from_path(path) == Format::OpenFoam) {
    std::string dir = openfoam_dir(path);
    if (dir.empty()) dir = no_trailing_slash(path);
    std::vector<std::string> out;
    for (const char* f : kFoamFileNames) out.push_back(dir + "/" + f);
    return out;
  }
  if (format_from_path(path) != Format::TetGen) return {path};
  const std::string base = stem(path);
  return {base + ".node", base + ".ele", base + ".face"};
}

namespace {
// An OpenFOAM output folder: it may not exist yet (the writer makes it and
// the folders above it); the nearest one that exists must be a folder we
// can write in, and the folder itself, if it exists, a folder.
Status check_foam_output(const std::string& path) {
  std::string p = no_trailing_slash(path);
  struct stat st {};
  if (::stat(p.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) return Status::error(ErrorCode::Io, shown(p) + ": exists and is not a folder (an OpenFOAM polyMesh is one)");
    return Status::success();
  }
  for (;;) {
    const size_t slash = p.rfind('/');
    p = slash == std::string::npos ? "." : (slash == 0 ? "/" : p.substr(0, slash));
    if (::stat(p.c_str(), &st) == 0) {
      if (!S_ISDIR(st.st_mode)) return Status::error(ErrorCode::Io, shown(p) + ": not a folder");
      if (::access(p.c_str(), W_OK | X_OK) != 0) return Status::error(ErrorCode::Io, shown(p) + ": cannot create folders in it: " + reason(errno));
      return Status::success();
    }
    if (p == "." || p == "/") return Status::error(ErrorCode::Io, shown(path) + ": no folder above it exists");
  }
}
// mkdir -p.
Status make_dirs(const std::string& path) {
  const std::string p = no_trailing_slash(path);
  if (is_dir(p)) return Status::success();
  const size_t slash = p.rfind('/');
  if (slash != std::string::npos && slash > 0)
    if (Status s = make_dirs(p.substr(0, slash)); !s) return s;
  if (::mkdir(p.c_str(), 0777) != 0 && errno != EEXIST)
    return Status::error(ErrorCode::Io, shown(p) + ": cannot create the folder: " + reason(errno));
  return Status::success();
}
}  // namespace

Status check_output_path(const std::string& path) {
  if (format_from_path(path) == Format::OpenFoam) {
    if (Status s = check_foam_output(path); !s) return s;
    if (!is_dir(no_trailing_slash(path))) return Status::success();  // made by the write
  }
  for (const std::string& f : mesh_files(path)) {
    std::string target;
    if (Status s = follow_links(f, target); !s) return s;
    if (Status s = check_one_output(f, target, true); !s) return s;
  }
  return Status::success();
}

Status write_file_atomic(const std::string& path, std::string_view bytes) { return write_files_atomic({{path, bytes}}); }

std::string output_target(const std::string& path) {
  std::string target;
  return follow_links(path, target) ? target : path;
}

void remove_pending_temporaries() noexcept {
  for (PendingTemp& p : g_pending)
    if (p.ready.load()) ::unlink(p.path);
}

namespace {
// A text file saved by some Windows editors starts with the UTF-8 byte order
// mark EF BB BF (Unicode Standard, section 23.8); it is not part of the first
// keyword.  The .msh and .vtk headers are text even in their binary variants;
// .meshb is binary from its first byte and keeps its bytes.
bool has_utf8_bom(std::string_view b) { return b.size() >= 3 && b.substr(0, 3) == "\xEF\xBB\xBF"; }

// A text file whose lines end with CR alone (classic Mac OS): no LF at all
// and some CR.  The readers count lines at LF, so every error named line 1
// (Medit) or the header looked empty (VTK, TetGen).  Such a file is read
// with its CRs made LFs (a copy; a binary file with no LF byte in it and
// its header lines ended by CR would be refused anyway).
bool cr_only(std::string_view b) {
  return !b.empty() && std::memchr(b.data(), '\n', b.size()) == nullptr &&
         std::memchr(b.data(), '\r', b.size()) != nullptr;
}
void cr_to_lf(std::string& s) { std::replace(s.begin(), s.end(), '\r', '\n'); }
}  // namespace

namespace {
// What a std::bad_alloc (or a length_error: a size past max_size) in reading
// or writing becomes: a one-line Status, never an abort (issue 25; every
// reader but Medit and TetGen used to end with exit 134).
template <typename F>
Status out_of_memory_guard(const std::string& path, const char* doing, F&& f) {
  try {
    return f();
  } catch (const std::bad_alloc&) {
  } catch (const std::length_error&) {
  }
  return Status::error(ErrorCode::OutOfMemory, shown(path) + ": out of memory " + doing);
}
Status read_mesh_unguarded(const std::string& path, TetMesh& m, OrientationReport* orient, int threads);
Status write_mesh_unguarded(const std::string& path, const TetMesh& m, const WriteOptions& opt);
}  // namespace

Status read_mesh(const std::string& path, TetMesh& m, OrientationReport* orient, int threads) {
  const Status s = out_of_memory_guard(path, "while reading (the mesh needs more memory than there is)",
                                       [&] { return read_mesh_unguarded(path, m, orient, threads); });
  if (s.code == ErrorCode::OutOfMemory) m = TetMesh{};  // release what was read
  return s;
}

Status write_mesh(const std::string& path, const TetMesh& m, const WriteOptions& opt) {
  return out_of_memory_guard(path, "while formatting the output; nothing written",
                             [&] { return write_mesh_unguarded(path, m, opt); });
}

namespace {
Status read_mesh_unguarded(const std::string& path, TetMesh& m, OrientationReport* orient, int threads) {
  m = TetMesh{};
  const Format f = format_from_path(path);
  Format actual = f;  // a .msh may turn out to be Fluent's
  // The name every message gives: control characters escaped, so that a
  // message stays one line for the library's callers too (Python).
  const std::string name = shown(path);
  std::string data;
  Status s;
  switch (f) {
    case Format::Unknown:
      return Status::error(ErrorCode::Unsupported,
                           name + ": unknown extension (use .mesh .meshb .msh .vtk .vtu .node/.ele .inp .cgns .exo, or a folder ending in polyMesh)");
    case Format::OpenFoam: {
      const std::string dir = openfoam_dir(path);
      if (dir.empty() || !is_dir(dir)) return Status::error(ErrorCode::Io, name + ": no such folder");
      std::string text[8];
      std::string_view views[8];
      for (int k = 0; k < 8; ++k) {
        const std::string fp = dir + "/" + kFoamFileNames[k];
        struct stat fst {};
        if (::stat(fp.c_str(), &fst) != 0) {
          if (::stat((fp + ".gz").c_str(), &fst) == 0)
            return Status::error(ErrorCode::Unsupported, shown(fp) + ".gz: compressed polyMesh files are not read (gunzip them first)");
          if (k < 4) return Status::error(ErrorCode::Io, shown(fp) + ": no such file");
          continue;  // boundary and zones may be absent
        }
        if (s = read_file_bytes(fp, text[k]); !s) return s;
        if (has_utf8_bom(text[k])) text[k].erase(0, 3);
        views[k] = text[k];
      }
      s = parse_openfoam(views, shown(dir), m);
      break;
    }
    case Format::Cgns: s = parse_cgns_file(path, name, m); break;
    case Format::Exodus: s = parse_exodus_file(path, name, m); break;
    case Format::TetGen: {
      const std::string base = stem(path);
      std::string ele, face;
      if (s = read_file_bytes(base + ".node", data); !s) return s;
      if (s = read_file_bytes(base + ".ele", ele); !s) return s;
      struct stat fst {};
      if (::stat((base + ".face").c_str(), &fst) == 0)  // optional; anything but a file is an error
        if (s = read_file_bytes(base + ".face", face); !s) return s;
      for (std::string* text : {&data, &ele, &face}) {
        if (has_utf8_bom(*text)) text->erase(0, 3);
        if (cr_only(*text)) cr_to_lf(*text);
      }
      s = parse_tetgen(data, ele, face, shown(base), m);
      break;
    }
    default: {
      MappedFile map;
      std::string_view bytes;
      if (map.open(path)) {
        bytes = map.view();
      } else {
        if (s = read_file_bytes(path, data); !s) return s;
        bytes = data;
      }
      if (f != Format::MeditBinary && has_utf8_bom(bytes)) bytes.remove_prefix(3);
      std::string lf;
      if (f != Format::MeditBinary && cr_only(bytes)) {
        lf.assign(bytes);
        cr_to_lf(lf);
        bytes = lf;
      }
      if (f == Format::Medit) s = parse_medit(bytes, name, m, threads);
      else if (f == Format::MeditBinary) s = parse_meditb(bytes, name, m);
      else if (f == Format::Gmsh && detail::looks_like_fluent(bytes)) {
        s = parse_fluent(bytes, name, m);
        actual = Format::Fluent;
      } else if (f == Format::Gmsh) s = parse_gmsh(bytes, name, m);
      else if (f == Format::Abaqus) s = parse_abaqus(bytes, name, m);
      else if (f == Format::Vtk) s = parse_vtk(bytes, name, m);
      else s = parse_vtu(bytes, name, m);
    }
  }
  if (!s) return s;
  m.source_format = static_cast<int>(actual);
  if (m.vert_ref.empty()) m.vert_ref.assign(m.nv(), 0);
  if (m.tet_ref.empty()) m.tet_ref.assign(m.nt(), 0);
  if (m.tri_ref.size() < static_cast<size_t>(m.ntri())) m.tri_ref.resize(m.ntri(), 0);
  if (m.edge_ref.size() < m.edges.size() / 2) m.edge_ref.resize(m.edges.size() / 2, 0);
  if (s = check_arrays(m, name, threads); !s) return s;
  OrientationReport r = normalize_orientation(m, threads);
  if (orient) *orient = std::move(r);
  return Status::success();
}
}  // namespace

bool msh_is_fluent(const TetMesh& m, const WriteOptions& opt) {
  if (opt.msh == WriteOptions::Msh::Auto) return m.source_format == static_cast<int>(Format::Fluent);
  return opt.msh == WriteOptions::Msh::Fluent;
}

std::vector<std::string> dropped_by_format(const TetMesh& m, Format f, const WriteOptions& opt) {
  if (f == Format::Gmsh && msh_is_fluent(m, opt)) f = Format::Fluent;
  std::vector<std::string> out;
  auto add = [&](int64_t n, const std::string& what, const char* unit = "") {
    if (n > 0) out.push_back(what + " (" + std::to_string(n) + unit + ")");
  };
  const bool medit = f == Format::Medit || f == Format::MeditBinary, gmsh = f == Format::Gmsh,
             vtk = f == Format::Vtk || f == Format::Vtu, tetgen = f == Format::TetGen,
             foam = f == Format::OpenFoam, fluent = f == Format::Fluent, abaqus = f == Format::Abaqus,
             cgns = f == Format::Cgns, exodus = f == Format::Exodus;
  // Formats that name groups themselves (patches, zones): the names of the
  // groups they write are kept; their writer's own list says what is not.
  const bool names_kept = gmsh || foam || fluent || abaqus || cgns || exodus;
  if (vtk) add(std::count_if(m.vert_ref.begin(), m.vert_ref.end(), [](int32_t r) { return r != 0; }), "vertex refs",
               " nonzero");
  if (gmsh) {  // a corner's ref is its point element's tag
    std::vector<uint8_t> corner(m.vert_ref.size(), 0);
    for (const int32_t c : m.corners)
      if (c >= 0 && static_cast<size_t>(c) < corner.size()) corner[static_cast<size_t>(c)] = 1;
    int64_t n = 0;
    for (size_t v = 0; v < m.vert_ref.size(); ++v) n += m.vert_ref[v] != 0 && !corner[v];
    add(n, "vertex refs", " nonzero");
  }
  if (tetgen || foam || fluent || abaqus || cgns || exodus) {
    add(static_cast<int64_t>(m.edges.size() / 2), "listed edges");
    add(static_cast<int64_t>(m.corners.size()), "corners");
  }
  if (!medit) {
    add(static_cast<int64_t>(m.required_vertices.size()), "required vertices");
    add(static_cast<int64_t>(m.required_edges.size()), "required edges");
    add(static_cast<int64_t>(m.required_tris.size()), "required triangles");
    add(static_cast<int64_t>(m.ridges.size()), "ridges");
  }
  if (!gmsh) {
    if (!names_kept) add(static_cast<int64_t>(m.physical_names.size()), "physical names");
    // Entity tags equal to the refs (as the Gmsh writers make them for a mesh
    // from another format) say nothing more.
    int64_t own = 0;
    for (size_t t = 0; t < m.tet_entity.size() && t < m.tet_ref.size(); ++t) own += m.tet_entity[t] != m.tet_ref[t];
    for (size_t t = 0; t < m.tri_entity.size() && t < m.tri_ref.size(); ++t) own += m.tri_entity[t] != m.tri_ref[t];
    add(own, "Gmsh elementary entity tags", " differing from the refs");
  }
  if (!gmsh || opt.msh_version == 22)
    add(std::count_if(m.gmsh_entities.begin(), m.gmsh_entities.end(),
                      [](const TetMesh::GmshEntity& e) { return e.physicals.size() > 1; }),
        "second physical groups of Gmsh entities", " entities");
  // Names the format's syntax cannot hold as they are: the writers put '_'
  // in place of the characters (a quoted Gmsh name ends at '"' or the line;
  // a legacy VTK name at a blank).
  if (gmsh)
    add(std::count_if(m.physical_names.begin(), m.physical_names.end(),
                      [](const PhysicalName& p) { return p.name.find_first_of("\"\n\r") != std::string::npos; }),
        "physical names with '\"' or a line break as they are", "; written with '_' in their place");
  if (f == Format::Vtk)
    add(std::count_if(m.point_fields.begin(), m.point_fields.end(),
                      [](const TetMesh::PointField& p) {
                        return p.name.empty() ||
                               std::any_of(p.name.begin(), p.name.end(), [](char c) {
                                 return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
                               });
                      }),
        "point data names with blanks (or empty) as they are", "; written with '_' in their place, 'field' if empty");
  // What the attachment says that only its own format writes (OpenFOAM
  // "wall" and "symmetryPlane" become Fluent "wall" / "symmetry" and back).
  if (!foam)
    add(std::count_if(m.attachment.groups.begin(), m.attachment.groups.end(),
                      [&](const GroupAttachment& g) {
                        const bool mapped = fluent && (g.foam_type == "wall" || g.foam_type == "symmetryPlane" ||
                                                       g.foam_type == "symmetry");
                        return !g.foam_entries.empty() || (!g.foam_type.empty() && g.foam_type != "patch" && !mapped);
                      }),
        "OpenFOAM patch types and entries", " patches");
  if (!fluent)
    add(std::count_if(m.attachment.groups.begin(), m.attachment.groups.end(),
                      [&](const GroupAttachment& g) {
                        const bool kept = foam && (g.fluent_type == "wall" || g.fluent_type == "symmetry");
                        return !kept && !g.fluent_type.empty() && g.fluent_type != "interior" && g.fluent_type != "fluid";
                      }),
        "Fluent zone types", " zones");
  if (foam)
    for (std::string& x : detail::openfoam_dropped(m)) out.push_back(std::move(x));
  if (fluent)
    for (std::string& x : detail::fluent_dropped(m)) out.push_back(std::move(x));
  if (abaqus)
    for (std::string& x : detail::abaqus_dropped(m)) out.push_back(std::move(x));
  if (cgns)
    for (std::string& x : detail::cgns_dropped(m)) out.push_back(std::move(x));
  if (exodus)
    for (std::string& x : detail::exodus_dropped(m)) out.push_back(std::move(x));
  if (!vtk && !m.point_fields.empty()) {
    std::string names;
    for (const TetMesh::PointField& p : m.point_fields) names += (names.empty() ? "" : ", ") + p.name;
    out.push_back("point data arrays (" + names + ")");
  }
  return out;
}

namespace {
// CGNS and Exodus II: their libraries write a file by name.  The file is
// written beside the target under a temporary name (listed, so that a
// signal handler removes it), read back and removed; write_file_atomic then
// puts those bytes in place like every other output.
Status library_file_bytes(const std::string& path, const TetMesh& m, Format f, std::string& out) {
  const std::string lib_tmp = temp_name(output_target(path)) + "-lib";
  const ListedTemp listed(lib_tmp);
  struct Remove {
    const std::string& p;
    ~Remove() { ::unlink(p.c_str()); }
  } remove{lib_tmp};
  Status s = f == Format::Cgns ? format_cgns_file(m, lib_tmp) : format_exodus_file(m, lib_tmp);
  if (!s) return Status::error(s.code, shown(path) + ": " + s.message);
  if (s = read_file_bytes(lib_tmp, out); !s) return Status::error(s.code, shown(path) + ": " + s.message);
  return Status::success();
}

Status write_mesh_unguarded(const std::string& path, const TetMesh& m, const WriteOptions& opt) {
  const Format f = format_from_path(path);
  std::string out;
  Status s;
  switch (f) {
    case Format::Unknown:
      return Status::error(ErrorCode::Unsupported,
                           shown(path) + ": unknown extension (use .mesh .meshb .msh .vtk .vtu .node/.ele .inp .cgns .exo, or a folder ending in polyMesh)");
    case Format::TetGen: {
      std::string ele, face;
      if (s = format_tetgen(m, out, ele, face); !s) return Status::error(s.code, shown(path) + ": " + s.message);
      // .face always written (possibly empty) so a stale .face never pairs
      // with new .node/.ele; the three files all or none.
      const std::vector<std::string> names = mesh_files(path);
      return write_files_atomic({{names[0], out}, {names[1], ele}, {names[2], face}});
    }
    case Format::OpenFoam: {
      std::string files[8];
      if (s = format_openfoam(m, files, opt.binary); !s) return Status::error(s.code, shown(path) + ": " + s.message);
      if (s = make_dirs(path); !s) return s;
      const std::vector<std::string> names = mesh_files(path);
      std::vector<std::pair<std::string, std::string_view>> set;
      for (int k = 0; k < 8; ++k) set.emplace_back(names[k], files[k]);
      return write_files_atomic(set);
    }
    case Format::Medit: return write_medit_streamed(path, m, opt.threads);
    case Format::MeditBinary: s = format_meditb(m, out, opt.meditb_version); break;
    case Format::Gmsh:
      s = msh_is_fluent(m, opt) ? format_fluent(m, out, opt.binary) : format_gmsh(m, out, opt.msh_version, opt.binary);
      break;
    case Format::Fluent: s = format_fluent(m, out, opt.binary); break;
    case Format::Abaqus: s = format_abaqus(m, out); break;
    case Format::Cgns:
    case Format::Exodus: {
      if (s = library_file_bytes(path, m, f, out); !s) return s;
      break;
    }
    case Format::Vtk: s = format_vtk(m, out, opt.binary); break;
    case Format::Vtu: s = format_vtu(m, out); break;
  }
  if (!s) return Status::error(s.code, shown(path) + ": " + s.message);
  return write_file_atomic(path, out);
}
}  // namespace

}  // namespace tetopt
