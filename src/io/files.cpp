// Files and images: whole-file reads, atomic writes (temporary + rename), image decode/encode
// through stb (Debian libstb), and the format-dispatching loadAsset with its post-processing.
#include <fcntl.h>
#include <signal.h>
#include <stb_image.h>
#include <stb_image_write.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <thread>

#include "duolod/io.hpp"

namespace duolod::io {
namespace fs = std::filesystem;
using core::Error;

namespace {
// The reader's warning that says why a file has no triangles (primitives or statements it
// skipped), as " (warning)"; "" when none does.
std::string whyNoTriangles(const std::vector<std::string>& warnings) {
  for (const std::string& warning : warnings)
    if (warning.find("skipped") != std::string::npos ||
        warning.find("ignored") != std::string::npos)
      return " (" + warning + ")";
  return "";
}
}  // namespace

core::Result<std::vector<uint8_t>> readFileBytes(const std::string& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);  // follows symbolic links
  if (!fs::exists(status)) return Error{path + ": file not found"};
  if (fs::is_directory(status)) return Error{path + ": is a folder, not a file"};
  // A device, pipe or socket is read until it ends, which /dev/zero never does (memory ran out)
  // and a pipe with no writer does not either (it waited for ever).
  if (!fs::is_regular_file(status))
    return Error{path + ": not a regular file (a device, pipe or socket)"};
  FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) return Error{path + ": cannot open (" + std::strerror(errno) + ")"};
  // In blocks, not through istreambuf_iterator: that pushed one byte at a time (~16 instructions
  // a byte, 45% of a whole bench_simplify run on Avocado under callgrind). The size is only a
  // hint: a file that grows or shrinks while read is read to its end.
  std::vector<uint8_t> bytes;
  const uintmax_t expected = fs::file_size(path, ec);
  size_t capacity = ec ? size_t(1) << 16 : size_t(expected) + 1;
  size_t size = 0;
  bool failed = false;
  for (;;) {
    bytes.resize(std::max(capacity, size + 1));
    const size_t got = std::fread(bytes.data() + size, 1, bytes.size() - size, file);
    size += got;
    if (size < bytes.size()) {
      failed = std::ferror(file) != 0;
      break;
    }
    capacity = bytes.size() * 2;
  }
  std::fclose(file);
  if (failed) return Error{path + ": read failed"};
  bytes.resize(size);
  return bytes;
}

namespace {
// Whether a file can be created in `folder` (permissions, a read-only or pseudo file system such
// as /proc): a probe file is created and removed. "" when it can, else the reason.
std::string cannotCreateIn(const fs::path& folder) {
  std::random_device entropy;
  const fs::path probe = folder / (".duolod-probe-" + std::to_string(::getpid()) + "-" +
                                   std::to_string(entropy() % 1000000));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0600);
  if (fd < 0) return std::strerror(errno);
  ::close(fd);
  ::unlink(probe.c_str());
  return "";
}
}  // namespace

namespace {
// The folder of an output file, when it exists and is a folder and the path is not a folder.
core::Result<fs::path> outputFolderOf(const std::string& path) {
  if (path.empty()) return Error{"empty output path"};
  fs::path target(path);
  std::error_code ec;
  fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  if (!fs::exists(folder, ec))
    return Error{path + ": folder " + folder.string() + " does not exist"};
  if (!fs::is_directory(folder, ec))
    return Error{path + ": " + folder.string() + " is not a folder"};
  if (fs::is_directory(target, ec)) return Error{path + ": is a folder"};
  return folder;
}
}  // namespace

core::Status checkWritablePath(const std::string& path) {
  auto folder = outputFolderOf(path);
  if (!folder) return folder.error();
  if (std::string reason = cannotCreateIn(*folder); !reason.empty())
    return Error{path + ": cannot create files in " + folder->string() + " (" + reason + ")"};
  return core::okStatus();
}

core::Result<bool> folderHoldsFiles(const std::string& folder) {
  std::error_code ec;
  fs::directory_iterator it(folder, ec), end;
  if (ec) return Error{folder + ": cannot read the folder (" + ec.message() + ")"};
  for (; it != end; it.increment(ec)) {
    if (ec) return Error{folder + ": cannot read the folder (" + ec.message() + ")"};
    // A killed run's staging folder is not the user's: OutputFolder::begin removes it.
    if (!it->path().filename().string().starts_with(".duolod-staging-")) return true;
  }
  return false;
}

core::Status checkWritableFolder(const std::string& folder) {
  if (folder.empty()) return Error{"empty output folder name"};
  std::error_code ec;
  const fs::path target = fs::absolute(folder, ec);
  const fs::file_status status = fs::status(target, ec);
  if (fs::exists(status) && !fs::is_directory(status))
    return Error{folder + ": exists and is not a folder"};
  // The folder, or the nearest folder above it that exists (the missing ones are created).
  fs::path existing = target;
  while (!fs::exists(existing, ec) && existing != existing.root_path())
    existing = existing.parent_path();
  if (!fs::is_directory(existing, ec))
    return Error{folder + ": " + existing.string() + " is not a folder"};
  if (std::string reason = cannotCreateIn(existing); !reason.empty())
    return Error{folder + ": cannot create files in " + existing.string() + " (" + reason + ")"};
  return core::okStatus();
}

namespace {
// The outputs a run has not finished, which removeUnfinishedOutputsOnInterrupt removes: FileSet
// temporaries, OutputFolder staging folders and the folders OutputFolder::begin made. Each is
// listed while it exists. `commit_mutex` is held while a commit moves files into place, so an
// interrupt waits for the commit (milliseconds) instead of leaving it half done. Never destroyed:
// the interrupt thread may use it while static objects are being destroyed.
class UnfinishedOutputs {
 public:
  enum class Kind : uint8_t { kFile, kTree, kMadeFolder };
  static UnfinishedOutputs& get() {
    static UnfinishedOutputs* outputs = new UnfinishedOutputs;
    return *outputs;
  }
  uint64_t add(Kind kind, std::string path) {
    std::lock_guard lock(mutex_);
    paths_.emplace(next_, Entry{kind, std::move(path)});
    return next_++;
  }
  void remove(uint64_t token) {
    if (token == 0) return;
    std::lock_guard lock(mutex_);
    paths_.erase(token);
  }
  std::recursive_mutex& commitMutex() { return commit_mutex_; }
  // Removes every listed output (files and staging folders, then the made folders, innermost
  // first, if empty); returns the paths removed.
  std::vector<std::string> removeAll() {
    std::lock_guard commit(commit_mutex_);
    std::lock_guard lock(mutex_);
    std::vector<std::string> removed;
    std::error_code ec;
    for (const auto& [token, entry] : paths_) {
      if (entry.kind == Kind::kMadeFolder) continue;
      if (entry.kind == Kind::kTree ? fs::remove_all(entry.path, ec) > 0
                                    : fs::remove(entry.path, ec))
        removed.push_back(entry.path);
    }
    for (const auto& [token, entry] : paths_)
      if (entry.kind == Kind::kMadeFolder && fs::remove(entry.path, ec))
        removed.push_back(entry.path);
    paths_.clear();
    return removed;
  }

 private:
  struct Entry {
    Kind kind;
    std::string path;
  };
  std::mutex mutex_;
  std::recursive_mutex commit_mutex_;
  uint64_t next_ = 1;
  std::map<uint64_t, Entry> paths_;  // in the order they were made
};

// A name beside `path` that no other file has: PATH<tag>-<pid>-<random> (same folder, so a rename
// between the two is atomic).
fs::path uniqueSibling(const fs::path& path, const char* tag) {
  std::random_device entropy;
  // A file name holds at most 255 bytes on the usual file systems: the name is shortened so that
  // the suffix fits (a valid 250-byte output name failed with "File name too long").
  constexpr size_t kNameMax = 255;
  const std::string name = path.filename().string();
  for (;;) {
    const std::string suffix = std::string(tag) + "-" + std::to_string(::getpid()) + "-" +
                               std::to_string(entropy() % 1000000);
    fs::path sibling = path.parent_path() /
                       (name.substr(0, kNameMax - std::min(kNameMax, suffix.size())) + suffix);
    std::error_code ec;
    if (!fs::exists(fs::symlink_status(sibling, ec))) return sibling;
  }
}
}  // namespace

FileSet::~FileSet() {
  std::error_code ec;
  for (const Staged& file : staged_) {
    fs::remove(file.temporary, ec);
    UnfinishedOutputs::get().remove(file.token);
  }
}

core::Status FileSet::add(const std::string& path, std::string_view text) {
  return add(path,
             std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
}

core::Status FileSet::checkTarget(const std::string& path) const {
  // (No probe file per file: writing the set's temporary names fails with the reason anyway.)
  if (auto folder = outputFolderOf(path); !folder) return folder.error();
  std::error_code ec;
  if (!replace_existing_ && fs::exists(path, ec))
    return Error{path + ": already exists, and replacing files was not asked for"};
  for (const Staged& file : staged_)
    if (file.target == path) return Error{path + ": written twice in one set"};
  return core::okStatus();
}

core::Status FileSet::add(const std::string& path, std::span<const uint8_t> bytes) {
  if (auto target = checkTarget(path); !target) return target;
  const fs::path temp = uniqueSibling(path, ".tmp");
  const uint64_t token =
      UnfinishedOutputs::get().add(UnfinishedOutputs::Kind::kFile, temp.string());
  FILE* file = std::fopen(temp.c_str(), "wb");
  if (!file) {
    UnfinishedOutputs::get().remove(token);
    return Error{path + ": cannot create (" + std::strerror(errno) + ")"};
  }
  size_t written = bytes.empty() ? 0 : std::fwrite(bytes.data(), 1, bytes.size(), file);
  bool flushed = std::fflush(file) == 0 && ::fsync(::fileno(file)) == 0;
  bool closed = std::fclose(file) == 0;
  if (written != bytes.size() || !flushed || !closed) {
    std::error_code ec;
    fs::remove(temp, ec);
    UnfinishedOutputs::get().remove(token);
    return Error{path + ": write failed (disk full?)"};
  }
  staged_.push_back({temp.string(), path, token});
  return core::okStatus();
}

core::Status FileSet::adopt(const std::string& written, const std::string& path) {
  // Only the set's own rules: a target that cannot take the file (a folder in the way) fails
  // its rename in commit(), which puts back what the set had moved until then.
  std::error_code ec;
  if (!replace_existing_ && fs::exists(fs::symlink_status(path, ec)))
    return Error{path + ": already exists, and replacing files was not asked for"};
  for (const Staged& file : staged_)
    if (file.target == path) return Error{path + ": written twice in one set"};
  staged_.push_back({written, path, 0});
  return core::okStatus();
}

core::Status FileSet::commit() {
  // An interrupt waits until the files are in place, or put back
  // (removeUnfinishedOutputsOnInterrupt).
  std::lock_guard committing(UnfinishedOutputs::get().commitMutex());
  // The temporaries are renamed or removed below, whatever happens.
  struct Forget {
    std::vector<uint64_t> tokens;
    ~Forget() {
      for (uint64_t token : tokens) UnfinishedOutputs::get().remove(token);
    }
  } forget;
  for (const Staged& file : staged_) forget.tokens.push_back(file.token);
  // Each rename is atomic, the set is not: the files that earlier renames replaced are kept (a
  // hard link to each, else a copy) until the last rename is done, so that a failure part-way
  // can put every target back as it was. The last rename needs no copy: nothing follows it.
  struct Placed {
    std::string target, kept;  // kept: the replaced file's copy ("" when there was none)
  };
  std::vector<Placed> placed;
  // A failed commit ends the set: the targets back as they were, the temporaries not moved yet
  // removed (the moved ones are gone).
  auto putBack = [&] {
    std::error_code ec;
    for (auto it = placed.rbegin(); it != placed.rend(); ++it) {
      if (it->kept.empty())
        fs::remove(it->target, ec);
      else
        fs::rename(it->kept, it->target, ec);
    }
    for (size_t i = placed.size(); i < staged_.size(); ++i) fs::remove(staged_[i].temporary, ec);
    staged_.clear();
  };
  for (size_t i = 0; i < staged_.size(); ++i) {
    const Staged file = staged_[i];  // a copy: putBack() clears the list
    std::error_code ec;
    std::string kept;
    const fs::file_status existing = fs::symlink_status(file.target, ec);
    if (i + 1 < staged_.size() && fs::exists(existing) && !fs::is_directory(existing)) {
      kept = uniqueSibling(file.target, ".old").string();
      fs::create_hard_link(file.target, kept, ec);
      if (ec) {  // a file system without hard links: a copy (of the link itself, for a link)
        ec.clear();
        if (fs::is_symlink(existing))
          fs::copy_symlink(file.target, kept, ec);
        else
          fs::copy_file(file.target, kept, ec);
      }
      if (ec) {
        const std::string reason = ec.message();
        fs::remove(kept, ec);
        putBack();
        return Error{file.target +
                     ": cannot keep the file it replaces until the output is in "
                     "place (" +
                     reason + "); nothing was replaced"};
      }
    }
    std::error_code rename_error;
    fs::rename(file.temporary, file.target, rename_error);
    if (rename_error) {
      if (!kept.empty()) fs::remove(kept, ec);
      putBack();
      return Error{file.target + ": cannot move the finished file into place (" +
                   rename_error.message() + "); the files written with it were taken back"};
    }
    placed.push_back({file.target, std::move(kept)});
  }
  std::error_code ec;
  for (const Placed& file : placed)
    if (!file.kept.empty()) fs::remove(file.kept, ec);
  staged_.clear();
  return core::okStatus();
}

OutputFolder::~OutputFolder() {
  abandon();
}

void OutputFolder::abandon() {
  std::error_code ec;
  if (!staging_.empty()) fs::remove_all(staging_, ec);
  staging_.clear();
  // Not committed: the folders begin() made go again (fs::remove takes only empty ones).
  for (const std::string& folder : created_) fs::remove(folder, ec);
  created_.clear();
  forgetUnfinished();
}

void OutputFolder::forgetUnfinished() {
  for (uint64_t token : unfinished_) UnfinishedOutputs::get().remove(token);
  unfinished_.clear();
}

core::Status OutputFolder::begin(const std::string& folder) {
  if (folder.empty()) return Error{"empty output folder name"};
  if (!staging_.empty()) return Error{folder + ": output folder begun twice"};
  std::error_code ec;
  // Through symbolic links: the staging folder must be on the real folder's file system.
  fs::path target = fs::weakly_canonical(fs::absolute(folder, ec), ec);
  if (ec) return Error{folder + ": cannot resolve the path (" + ec.message() + ")"};
  if (target.filename().empty()) target = target.parent_path();  // "out/" -> "out"
  if (target == target.root_path())
    return Error{folder + ": cannot write an output into the root folder"};
  const fs::file_status status = fs::status(target, ec);
  if (fs::exists(status) && !fs::is_directory(status))
    return Error{folder + ": exists and is not a folder"};
  // The folder and the parents it lacks, innermost first (removed again, innermost first, unless
  // committed).
  // (symlink_status: a dangling symbolic link is there, not missing, and is never removed.)
  for (fs::path missing = target;
       !fs::exists(fs::symlink_status(missing, ec)) && missing != missing.root_path();
       missing = missing.parent_path())
    created_.push_back(missing.string());
  for (const std::string& made : created_)  // innermost first
    unfinished_.push_back(UnfinishedOutputs::get().add(UnfinishedOutputs::Kind::kMadeFolder, made));
  fs::create_directories(target, ec);
  if (ec) return Error{folder + ": cannot create (" + ec.message() + ")"};
  // Staging folders of runs that were killed (their process is gone) are removed.
  for (fs::directory_iterator it(target, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    constexpr std::string_view kPrefix = ".duolod-staging-";
    if (!name.starts_with(kPrefix)) continue;
    const long pid = std::strtol(name.c_str() + kPrefix.size(), nullptr, 10);
    std::error_code remove_ec;
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH)
      fs::remove_all(it->path(), remove_ec);
  }
  ec.clear();
  // Inside the folder, hidden: on its file system even when the folder is a mount point (a
  // container's volume), so that commit() only renames.
  const fs::path staging = uniqueSibling(target / ".duolod-staging", "");
  unfinished_.push_back(
      UnfinishedOutputs::get().add(UnfinishedOutputs::Kind::kTree, staging.string()));
  if (!fs::create_directory(staging, ec) || ec)
    return Error{folder + ": cannot create the staging folder " + staging.string() + " (" +
                 (ec ? ec.message() : std::string("it exists")) + ")"};
  folder_ = target.string();
  staging_ = staging.string();
  return core::okStatus();
}

core::Status OutputFolder::commit(const core::Asset* asset) {
  if (staging_.empty()) return Error{"output folder: commit() before begin()"};
  // An interrupt waits until the files are in place, or the folder is back as it was.
  std::lock_guard committing(UnfinishedOutputs::get().commitMutex());
  // A failed commit ends the output: the folder is left as it was.
  auto failed = [this](core::Status status) {
    abandon();
    return status;
  };
  std::error_code ec;
  const fs::path target(folder_);
  // The staged files in name order (a deterministic commit), sub-folders included.
  std::vector<fs::path> files, folders;
  for (auto it = fs::recursive_directory_iterator(staging_, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (it->is_directory(ec))
      folders.push_back(it->path());
    else
      files.push_back(it->path());
  }
  if (ec) return failed(Error{staging_ + ": cannot list the staged output (" + ec.message() + ")"});
  std::sort(files.begin(), files.end());
  std::sort(folders.begin(), folders.end());
  auto targetOf = [&](const fs::path& staged) {
    return (target / staged.lexically_relative(staging_)).string();
  };
  if (asset)
    for (const fs::path& file : files)
      if (auto refused = refuseSourceFile(*asset, targetOf(file)); !refused) return failed(refused);

  // Sub-folders first (those this makes are removed again if the files cannot be moved).
  std::vector<fs::path> made;
  auto removeMade = [&] {
    std::error_code remove_ec;
    for (auto it = made.rbegin(); it != made.rend(); ++it) fs::remove(*it, remove_ec);
  };
  for (const fs::path& staged_folder : folders) {
    const fs::path folder = targetOf(staged_folder);
    if (fs::is_directory(folder, ec)) continue;
    if (!fs::create_directory(folder, ec) || ec) {
      removeMade();
      return failed(Error{folder.string() + ": cannot create (" +
                          (ec ? ec.message() : std::string("a file has that name")) + ")"});
    }
    made.push_back(folder);
  }
  FileSet set(/*replace_existing=*/true);
  for (const fs::path& file : files) {
    if (auto adopted = set.adopt(file.string(), targetOf(file)); !adopted) {
      removeMade();
      return failed(adopted);
    }
  }
  if (auto committed = set.commit(); !committed) {
    removeMade();
    return failed(committed);
  }
  fs::remove_all(staging_, ec);
  staging_.clear();
  created_.clear();  // in place: kept
  forgetUnfinished();
  return core::okStatus();
}

void removeUnfinishedOutputsOnInterrupt(const std::string& program) {
  static std::once_flag once;
  std::call_once(once, [program] {
    sigset_t signals;
    sigemptyset(&signals);
    for (int signal : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&signals, signal);
    // Blocked here, so in every thread started after this; taken by sigwait on a thread of its
    // own, which may do what a signal handler may not (remove folders, take locks).
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    std::thread([signals, program] {
      int signal = 0;
      while (sigwait(&signals, &signal) != 0) {
      }
      const std::vector<std::string> removed = UnfinishedOutputs::get().removeAll();
      std::string message = (program.empty() ? "" : program + ": ") + "interrupted (" +
                            (signal == SIGINT    ? "SIGINT"
                             : signal == SIGTERM ? "SIGTERM"
                                                 : "SIGHUP") +
                            ")";
      message += removed.empty() ? "; no unfinished output to remove\n"
                                 : "; removed the unfinished output:\n";
      for (const std::string& path : removed) message += "  " + path + "\n";
      // write(2), not stdio: another thread may hold stderr's lock.
      for (size_t done = 0; done < message.size();) {
        const ssize_t n = ::write(STDERR_FILENO, message.data() + done, message.size() - done);
        if (n <= 0) break;
        done += size_t(n);
      }
      ::_exit(128 + signal);
    }).detach();
  });
}

core::Status writeFileAtomic(const std::string& path, std::span<const uint8_t> bytes) {
  FileSet file;
  if (auto added = file.add(path, bytes); !added) return added;
  return file.commit();
}

core::Status writeFileAtomic(const std::string& path, std::string_view text) {
  return writeFileAtomic(
      path, std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
}

namespace {
// stb's RGBA pixels of an image file, freed with the value.
struct StbPixels {
  std::unique_ptr<stbi_uc, void (*)(void*)> data{nullptr, stbi_image_free};
  int width = 0, height = 0;
};

core::Result<StbPixels> decodeWithStb(std::span<const uint8_t> bytes, const std::string& name) {
  if (bytes.empty()) return Error{name + ": empty image"};
  if (bytes.size() > static_cast<size_t>(INT32_MAX)) return Error{name + ": image file too large"};
  StbPixels decoded;
  int channels = 0;
  decoded.data.reset(stbi_load_from_memory(bytes.data(), static_cast<int>(bytes.size()),
                                           &decoded.width, &decoded.height, &channels, 4));
  if (!decoded.data) return Error{name + ": cannot decode image (" + stbi_failure_reason() + ")"};
  return decoded;
}
}  // namespace

core::Result<core::ImageRGBA8> decodeImage(std::span<const uint8_t> bytes, const std::string& name) {
  auto decoded = decodeWithStb(bytes, name);
  if (!decoded) return decoded.error();
  core::ImageRGBA8 image;
  image.width = decoded->width;
  image.height = decoded->height;
  const stbi_uc* pixels = decoded->data.get();
  image.pixels.assign(pixels, pixels + static_cast<size_t>(image.width) * image.height * 4);
  return image;
}

core::Result<core::ImageRGBA8> readImage(const std::string& path) {
  auto bytes = readFileBytes(path);
  if (!bytes) return bytes.error();
  return decodeImage(*bytes, path);
}

std::vector<uint8_t> encodePng(const core::ImageRGBA8& image) {
  std::vector<uint8_t> out;
  if (!core::validateImage(image)) return out;  // empty: the callers' "encoding failed"
  stbi_write_png_to_func(
      [](void* context, void* data, int size) {
        auto* sink = static_cast<std::vector<uint8_t>*>(context);
        auto* begin = static_cast<uint8_t*>(data);
        sink->insert(sink->end(), begin, begin + size);
      },
      &out, image.width, image.height, 4, image.pixels.data(), image.width * 4);
  return out;
}

namespace {
// "image/png", "image/jpeg", or empty: the formats glTF takes, by their magic numbers.
std::string imageMimeType(std::span<const uint8_t> bytes) {
  static constexpr uint8_t kPng[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static constexpr uint8_t kJpeg[] = {0xff, 0xd8, 0xff};
  auto starts = [&](std::span<const uint8_t> magic) {
    return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin());
  };
  return starts(kPng) ? "image/png" : starts(kJpeg) ? "image/jpeg" : "";
}
}  // namespace

std::shared_ptr<const core::EncodedImage> keepEncoded(std::span<const uint8_t> bytes,
                                                      const core::ImageRGBA8& decoded) {
  std::string mime_type = imageMimeType(bytes);
  if (mime_type.empty() || decoded.pixels.empty()) return nullptr;
  auto encoded = std::make_shared<core::EncodedImage>();
  encoded->bytes.assign(bytes.begin(), bytes.end());
  encoded->mime_type = std::move(mime_type);
  encoded->width = decoded.width;
  encoded->height = decoded.height;
  encoded->image_fingerprint = core::fingerprintImage(decoded);
  return encoded;
}

namespace {
uint32_t bigEndian32(const uint8_t* p) {
  return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
}

// CRC-32 as PNG defines it (ISO 3309 polynomial, reflected; PNG spec §5.5), eight bytes a step
// ("slicing by 8": table k advances a byte's remainder by k more bytes): 0.4-0.8 ms a MB,
// against 2.2 ms a MB a byte at a time (a tenth of an undecoded WaterBottle simplify).
uint32_t pngCrc(std::span<const uint8_t> bytes) {
  static const auto tables = [] {
    std::array<std::array<uint32_t, 256>, 8> t{};
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xedb88320u ^ (c >> 1) : c >> 1;
      t[0][n] = c;
    }
    for (uint32_t n = 0; n < 256; ++n)
      for (size_t k = 1; k < 8; ++k) t[k][n] = t[0][t[k - 1][n] & 0xff] ^ (t[k - 1][n] >> 8);
    return t;
  }();
  uint32_t crc = 0xffffffffu;
  const uint8_t* p = bytes.data();
  size_t left = bytes.size();
  for (; left >= 8; left -= 8, p += 8) {
    const uint32_t low = crc ^ (uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 |
                                uint32_t(p[3]) << 24);
    crc = tables[7][low & 0xff] ^ tables[6][(low >> 8) & 0xff] ^ tables[5][(low >> 16) & 0xff] ^
          tables[4][low >> 24] ^ tables[3][p[4]] ^ tables[2][p[5]] ^ tables[1][p[6]] ^
          tables[0][p[7]];
  }
  for (; left > 0; --left, ++p) crc = tables[0][(crc ^ *p) & 0xff] ^ (crc >> 8);
  return crc ^ 0xffffffffu;
}

// Whether a PNG's chunks are whole and intact: IHDR first, at least one IDAT, IEND, and every
// chunk's CRC right (PNG spec §5.3). The CRCs are what catches damaged image data without
// inflating it: 3.5 ms for WaterBottle's four PNGs (8.8 MB), where decoding them takes 0.24 s.
bool pngChunksIntact(std::span<const uint8_t> bytes) {
  if (bytes.size() < 8) return false;
  size_t at = 8;  // after the signature
  bool first = true, has_data = false;
  while (bytes.size() - at >= 12) {
    const uint32_t length = bigEndian32(&bytes[at]);
    if (length > 0x7fffffffu || length > bytes.size() - at - 12) return false;
    const uint8_t* type = &bytes[at + 4];
    if (pngCrc(bytes.subspan(at + 4, 4 + size_t(length))) != bigEndian32(type + 4 + length))
      return false;
    if (first && std::memcmp(type, "IHDR", 4) != 0) return false;
    first = false;
    // A critical chunk (first letter upper case, §5.4) that a decoder must know: only the four
    // of the core format (stb refuses any other).
    const bool critical = (type[0] & 0x20) == 0;
    if (critical && std::memcmp(type, "IHDR", 4) != 0 && std::memcmp(type, "PLTE", 4) != 0 &&
        std::memcmp(type, "IDAT", 4) != 0 && std::memcmp(type, "IEND", 4) != 0)
      return false;
    if (std::memcmp(type, "IDAT", 4) == 0) has_data = true;
    if (std::memcmp(type, "IEND", 4) == 0) return has_data;
    at += 12 + size_t(length);
  }
  return false;  // cut short before IEND
}

// Whether a JPEG's marker segments are whole (ITU T.81 Annex B) and of the kinds stb decodes: SOI,
// quantization and Huffman tables and a baseline, extended or progressive frame header (SOF0-2)
// before the first scan, besides them only restart intervals, APPn and comments, every segment's
// length inside the file, restarts only inside a scan's entropy-coded data, which a marker ends,
// and EOI at the end. Anything else is decoded to be judged. JPEG carries no checksum: damage
// inside the tables' contents or a scan's data is found only by decoding it.
bool jpegSegmentsIntact(std::span<const uint8_t> bytes) {
  size_t at = 2;  // after SOI
  bool frame = false, quantization = false, huffman = false;
  while (at < bytes.size()) {
    if (bytes[at] != 0xff) return false;
    while (at < bytes.size() && bytes[at] == 0xff) ++at;  // fill bytes
    if (at == bytes.size()) return false;
    const uint8_t marker = bytes[at++];
    if (marker == 0xd9) return frame;  // EOI
    const bool sof = marker >= 0xc0 && marker <= 0xc2;
    const bool known = sof || marker == 0xc4 || marker == 0xdb || marker == 0xdd ||
                       marker == 0xda || marker == 0xfe || (marker >= 0xe0 && marker <= 0xef);
    if (!known) return false;
    if (bytes.size() - at < 2) return false;
    const size_t length = size_t(bytes[at]) << 8 | bytes[at + 1];
    if (length < 2 || length > bytes.size() - at) return false;
    frame = frame || sof;
    quantization = quantization || marker == 0xdb;
    huffman = huffman || marker == 0xc4;
    at += length;
    if (marker == 0xda) {  // SOS: entropy-coded data up to the next marker that is not a stuffed
                           // zero or a restart
      if (!frame || !quantization || !huffman) return false;
      for (;;) {
        const uint8_t* next = static_cast<const uint8_t*>(
            std::memchr(bytes.data() + at, 0xff, bytes.size() - at));
        if (!next) return false;
        at = size_t(next - bytes.data());
        if (at + 1 >= bytes.size()) return false;
        const uint8_t following = bytes[at + 1];
        if (following == 0x00 || (following >= 0xd0 && following <= 0xd7) || following == 0xff) {
          at += following == 0xff ? 1 : 2;
          continue;
        }
        break;
      }
    }
  }
  return false;
}

}  // namespace

core::Result<std::shared_ptr<const core::EncodedImage>> keepUndecoded(
    std::span<const uint8_t> bytes, const std::string& name) {
  std::string mime_type = imageMimeType(bytes);
  if (mime_type.empty()) return std::shared_ptr<const core::EncodedImage>();
  if (bytes.size() > static_cast<size_t>(INT32_MAX)) return Error{name + ": image file too large"};
  int width = 0, height = 0, channels = 0;
  if (!stbi_info_from_memory(bytes.data(), static_cast<int>(bytes.size()), &width, &height,
                             &channels) ||
      width <= 0 || height <= 0) {
    const char* reason = stbi_failure_reason();
    return Error{name + ": cannot read the " + (mime_type == "image/png" ? "PNG" : "JPEG") +
                 " header" + (reason ? std::string(" (") + reason + ")" : std::string())};
  }
  // A file whose structure is damaged or unusual is decoded after all, so that it is accepted or
  // refused as when every texture is decoded (stb reads some PNGs with a wrong CRC). A PNG's
  // chunks carry CRCs, which is as far as it is checked (its zlib stream under right CRCs goes
  // through unread). A JPEG carries no checksum, and damage to its tables or scan data shows only
  // when decoding: stb refused about half of 200 one-byte changes to a scan, which the segment
  // check passed. So a JPEG is decoded here too, and its pixels dropped: 10-20 ms for a 2048²
  // photo, against the PNG encoding that keeping the bytes saves, and one image's pixels in
  // memory at a time (bench/RESULTS.md, session 26).
  const bool intact = mime_type == "image/png" ? pngChunksIntact(bytes) : jpegSegmentsIntact(bytes);
  if (!intact) return std::shared_ptr<const core::EncodedImage>();
  if (mime_type == "image/jpeg") {  // pixels dropped at once; refused here, not decoded twice
    auto decoded = decodeWithStb(bytes, name);
    if (!decoded) return decoded.error();
  }
  auto encoded = std::make_shared<core::EncodedImage>();
  encoded->bytes.assign(bytes.begin(), bytes.end());
  encoded->mime_type = std::move(mime_type);
  encoded->width = width;
  encoded->height = height;
  return std::shared_ptr<const core::EncodedImage>(std::move(encoded));
}

core::Result<core::Texture> readTextureFile(const std::string& path, bool srgb, bool decode) {
  auto bytes = readFileBytes(path);
  if (!bytes) return bytes.error();
  core::Texture texture{.name = path, .image = {}, .srgb = srgb};
  if (!decode) {
    auto kept = keepUndecoded(*bytes, path);
    if (!kept) return kept.error();
    texture.encoded = std::move(kept).value();
    if (texture.encoded) return texture;
  }
  auto image = decodeImage(*bytes, path);
  if (!image) return image.error();
  texture.image = std::move(image).value();
  texture.encoded = keepEncoded(*bytes, texture.image);
  return texture;
}

TextureFile textureFile(const core::Texture& texture) {
  const core::EncodedImage* source = texture.encoded.get();
  if (source && (texture.image.pixels.empty() ||
                 core::fingerprintImage(texture.image) == source->image_fingerprint)) {
    return {source->bytes, source->mime_type, source->mime_type == "image/jpeg" ? ".jpg" : ".png",
            true};
  }
  return {encodePng(texture.image), "image/png", ".png", false};
}

core::Status writePng(const core::ImageRGBA8& image, const std::string& path) {
  if (auto valid = core::validateImage(image); !valid)
    return Error{path + ": " + valid.error().message};
  std::vector<uint8_t> png = encodePng(image);
  if (png.empty()) return Error{path + ": PNG encoding failed"};
  return writeFileAtomic(path, png);
}

namespace {

// Many OBJ files ship without an .mtl but with their texture beside them (Keenan Crane's Spot:
// spot.obj + spot_texture.png). When a textured-looking OBJ has no texture at all, adopt a single
// image named after it as the base colour, and say so.
void adoptSiblingTexture(core::Asset& asset, const std::string& path, const LoadOptions& options) {
  if (!options.load_textures || asset.mesh.uv0.empty() || !asset.textures.empty()) return;
  fs::path source(path);
  std::string stem = source.stem().string();
  for (const char* suffix : {"_texture", "_diffuse", "_albedo", "_basecolor", ""}) {
    for (const char* extension : {".png", ".jpg", ".jpeg"}) {
      fs::path candidate = source.parent_path() / (stem + suffix + extension);
      std::error_code ec;
      if (!fs::is_regular_file(candidate, ec)) continue;
      auto texture = readTextureFile(candidate.string(), true, options.decode_textures);
      if (!texture) {
        asset.warnings.push_back(texture.error().message);
        return;
      }
      texture->name = candidate.filename().string();
      asset.textures.push_back(std::move(texture).value());
      asset.source_files.push_back(candidate.string());
      if (asset.materials.empty()) asset.materials.push_back(core::Material{.name = "default"});
      for (core::Material& material : asset.materials) material.base_color_texture = 0;
      asset.warnings.push_back("no material texture; using " + candidate.filename().string() +
                               " found beside it as the base colour");
      return;
    }
  }
}

}  // namespace

core::Result<core::Asset> loadAsset(const std::string& path, const LoadOptions& options) {
  std::string extension = fs::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
  std::error_code ec;
  if (!fs::exists(path, ec)) return Error{path + ": file not found"};
  if (fs::is_directory(path, ec)) return Error{path + ": is a folder, not a file"};
  core::Result<core::Asset> loaded = Error{};
  if (extension == ".gltf" || extension == ".glb")
    loaded = readGltf(path, options);
  else if (extension == ".obj")
    loaded = readObj(path, options);
  else if (extension == ".ply")
    loaded = readPly(path, options);
  else if (extension == ".off")
    loaded = readOff(path, options);
  else
    return Error{path + ": unsupported file type '" + extension +
                 "' (supported: .gltf .glb .obj .ply .off)"};
  if (!loaded) return loaded;
  core::Asset& asset = loaded.value();
  core::Mesh& mesh = asset.mesh;
  if (extension == ".obj") adoptSiblingTexture(asset, path, options);
  if (mesh.submeshes.empty() && !mesh.indices.empty())
    mesh.submeshes.push_back({0, static_cast<uint32_t>(mesh.indices.size()), 0});
  if (asset.materials.empty()) asset.materials.push_back(core::Material{.name = "default"});
  if (auto valid = core::validateMesh(mesh); !valid) return Error{path + ": " + valid.error().message};
  for (const core::Submesh& sub : mesh.submeshes)
    if (sub.material >= asset.materials.size())
      return Error{path + ": submesh refers to material " + std::to_string(sub.material) +
                   " but there are " + std::to_string(asset.materials.size())};
  size_t degenerate = core::removeDegenerateTriangles(mesh);
  if (degenerate > 0)
    asset.warnings.push_back(std::to_string(degenerate) + " degenerate triangles removed");
  if (mesh.triangleCount() == 0)
    return Error{path + (degenerate > 0 ? ": all " + std::to_string(degenerate) +
                                              " triangles are degenerate (zero area)"
                                        : ": the file contains no triangles" +
                                              whyNoTriangles(asset.warnings))};
  if (size_t off = core::normalizeNormals(mesh); off > 0)
    asset.warnings.push_back(std::to_string(off) + " normals were not of unit length; normalized");
  // A zero normal (OBJ's `vn 0 0 0`) has no direction to light by: it takes the surface's
  // angle-weighted normal there (of the unwelded mesh: across a seam, its own side's).
  if (!mesh.normals.empty()) {
    std::vector<uint32_t> zero;
    for (uint32_t v = 0; v < mesh.normals.size(); ++v)
      if (!(core::dot(mesh.normals[v], mesh.normals[v]) > 0)) zero.push_back(v);
    if (!zero.empty()) {
      core::Mesh surface;
      surface.positions = mesh.positions;
      surface.indices = mesh.indices;
      core::computeNormals(surface);
      for (uint32_t v : zero) mesh.normals[v] = surface.normals[v];
      asset.warnings.push_back(std::to_string(zero.size()) +
                               " normals were zero; the surface's normals used there");
    }
  }
  if (options.weld) core::weldVertices(mesh);
  if (options.generate_normals && mesh.normals.empty()) core::computeNormals(mesh);
  if (options.generate_tangents && mesh.tangents.empty() && !mesh.normals.empty() &&
      !mesh.uv0.empty())
    core::computeTangentsPerSubmesh(mesh, core::normalMappedSubmeshes(asset));
  asset.source_path = path;
  asset.source_files.push_back(path);
  return loaded;
}

core::Status refuseSourceFile(const core::Asset& asset, const std::string& output) {
  std::error_code ec;
  const bool exists = fs::exists(output, ec);
  const fs::path canonical = fs::weakly_canonical(output, ec);
  auto same = [&](const std::string& source) {
    if (source.empty()) return false;
    std::error_code source_ec;
    if (exists && fs::exists(source, source_ec)) return fs::equivalent(output, source, source_ec);
    return fs::weakly_canonical(source, source_ec) == canonical;
  };
  if (same(asset.source_path) ||
      std::any_of(asset.source_files.begin(), asset.source_files.end(), same))
    return Error{output + ": is a file the asset was read from; refusing to replace it"};
  return core::okStatus();
}

}  // namespace duolod::io
