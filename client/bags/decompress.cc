#include "client/bags/decompress.h"

#include <bzlib.h>
#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <cstdio>
#include <memory>

#include "absl/strings/str_cat.h"

namespace waymark::bags {
namespace {

// The output buffer grows by at most this much at a time beyond the input's size.
constexpr uint64_t kGrowStep = uint64_t{16} << 20;

// Grows `out` so that it has room after `used`, never beyond `limit`.
bool Grow(std::string* out, size_t used, uint64_t limit) {
  if (used >= limit) return false;
  const uint64_t want = std::min<uint64_t>(limit, used + std::max<uint64_t>(kGrowStep, used));
  out->resize(want);
  return true;
}

uint64_t InitialSize(std::string_view input, uint64_t limit) {
  return std::min<uint64_t>(limit, std::max<uint64_t>(4096, input.size() * 4));
}

absl::StatusOr<std::string> Bz2(std::string_view input, uint64_t limit, bool cut_ok) {
  bz_stream stream{};
  if (BZ2_bzDecompressInit(&stream, 0, 0) != BZ_OK) return absl::InternalError("bz2: init failed");
  std::string out(InitialSize(input, limit), '\0');
  stream.next_in = const_cast<char*>(input.data());
  stream.avail_in = static_cast<unsigned>(input.size());
  size_t used = 0;
  int code = BZ_OK;
  while (true) {
    if (used == out.size() && !Grow(&out, used, limit + 1)) break;
    const size_t room = std::min<size_t>(out.size() - used, 1u << 30);
    stream.next_out = out.data() + used;
    stream.avail_out = static_cast<unsigned>(room);
    code = BZ2_bzDecompress(&stream);
    used += room - stream.avail_out;
    if (code == BZ_STREAM_END || code != BZ_OK) break;
    if (stream.avail_in == 0 && stream.avail_out != 0) break;  // input ended mid-stream
  }
  BZ2_bzDecompressEnd(&stream);
  if (code == BZ_OK && cut_ok && used <= limit) {
    out.resize(used);
    return out;
  }
  if (code != BZ_STREAM_END) {
    if (used > limit) return absl::DataLossError(absl::StrCat("bz2: expands past ", limit, " bytes"));
    return absl::DataLossError(code == BZ_OK ? "bz2: stream truncated"
                                             : absl::StrCat("bz2: damaged stream (code ", code, ")"));
  }
  out.resize(used);
  return out;
}

absl::StatusOr<std::string> Lz4Frame(std::string_view input, uint64_t limit, bool cut_ok) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) {
    return absl::InternalError("lz4: init failed");
  }
  std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> context(
      raw, &LZ4F_freeDecompressionContext);
  std::string out(InitialSize(input, limit), '\0');
  size_t used = 0;
  size_t consumed = 0;
  size_t hint = 1;
  while (consumed < input.size()) {
    if (used == out.size() && !Grow(&out, used, limit + 1)) {
      return absl::DataLossError(absl::StrCat("lz4: expands past ", limit, " bytes"));
    }
    size_t out_size = out.size() - used;
    size_t in_size = input.size() - consumed;
    hint = LZ4F_decompress(context.get(), out.data() + used, &out_size, input.data() + consumed,
                           &in_size, nullptr);
    if (LZ4F_isError(hint)) {
      return absl::DataLossError(absl::StrCat("lz4: ", LZ4F_getErrorName(hint)));
    }
    used += out_size;
    consumed += in_size;
    if (hint == 0) break;  // frame complete
    if (in_size == 0 && out_size == 0) break;
  }
  if (hint != 0 && !cut_ok) return absl::DataLossError("lz4: frame truncated");
  if (used > limit) return absl::DataLossError(absl::StrCat("lz4: expands past ", limit, " bytes"));
  out.resize(used);
  return out;
}

absl::StatusOr<std::string> Zstd(std::string_view input, uint64_t limit, bool cut_ok = false) {
  // One context per thread, reset per stream: creating one costs more than expanding a small
  // rosbag2 message (per-message compression expands thousands of them).
  thread_local std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> context(ZSTD_createDCtx(),
                                                                             &ZSTD_freeDCtx);
  if (!context) return absl::InternalError("zstd: init failed");
  ZSTD_DCtx_reset(context.get(), ZSTD_reset_session_only);
  std::string out(InitialSize(input, limit), '\0');
  ZSTD_inBuffer in{input.data(), input.size(), 0};
  size_t used = 0;
  size_t code = 1;
  while (true) {
    if (used == out.size() && !Grow(&out, used, limit + 1)) {
      return absl::DataLossError(absl::StrCat("zstd: expands past ", limit, " bytes"));
    }
    ZSTD_outBuffer buffer{out.data() + used, out.size() - used, 0};
    code = ZSTD_decompressStream(context.get(), &buffer, &in);
    if (ZSTD_isError(code)) return absl::DataLossError(absl::StrCat("zstd: ", ZSTD_getErrorName(code)));
    used += buffer.pos;
    if (code == 0 && in.pos == in.size) break;  // every frame complete
    if (in.pos == in.size && buffer.pos < buffer.size) break;  // input ended mid-frame
  }
  if (code != 0 && !cut_ok) return absl::DataLossError("zstd: stream truncated");
  if (used > limit) return absl::DataLossError(absl::StrCat("zstd: expands past ", limit, " bytes"));
  out.resize(used);
  return out;
}

}  // namespace

absl::StatusOr<Compression> ParseCompression(std::string_view name) {
  if (name.empty() || name == "none") return Compression::kNone;
  if (name == "bz2") return Compression::kBz2;
  if (name == "lz4") return Compression::kLz4;
  if (name == "zstd") return Compression::kZstd;
  return absl::UnimplementedError(
      absl::StrCat("compression \"", std::string(name), "\" is not one this reader knows (none, bz2, lz4, zstd)"));
}

const char* CompressionName(Compression compression) {
  switch (compression) {
    case Compression::kNone: return "none";
    case Compression::kBz2: return "bz2";
    case Compression::kLz4: return "lz4";
    case Compression::kZstd: return "zstd";
  }
  return "none";
}

absl::StatusOr<std::string> Decompress(Compression compression, std::string_view input,
                                       uint64_t expected_size, bool exact, bool cut_ok) {
  if (expected_size > kMaxExpandedBytes) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "declared size of ", expected_size, " bytes is over the reader's limit of ",
        kMaxExpandedBytes, " bytes"));
  }
  absl::StatusOr<std::string> out;
  switch (compression) {
    case Compression::kNone: out = std::string(input); break;
    case Compression::kBz2: out = Bz2(input, expected_size, cut_ok); break;
    case Compression::kLz4: out = Lz4Frame(input, expected_size, cut_ok); break;
    case Compression::kZstd: out = Zstd(input, expected_size, cut_ok); break;
  }
  if (!out.ok()) return out;
  if (exact && out->size() != expected_size) {
    return absl::DataLossError(absl::StrCat(CompressionName(compression), ": expanded to ",
                                            out->size(), " bytes, declared ", expected_size));
  }
  return out;
}

absl::StatusOr<std::string> DecompressZstdUpTo(std::string_view input, uint64_t limit) {
  return Zstd(input, std::min(limit, kMaxExpandedBytes));
}

absl::Status DecompressZstdFile(const std::string& from_path, const std::string& to_path) {
  std::unique_ptr<FILE, decltype(&std::fclose)> in(std::fopen(from_path.c_str(), "rb"), &std::fclose);
  if (!in) return absl::NotFoundError(absl::StrCat(from_path, ": cannot open"));
  std::unique_ptr<FILE, decltype(&std::fclose)> out(std::fopen(to_path.c_str(), "wb"), &std::fclose);
  if (!out) return absl::PermissionDeniedError(absl::StrCat(to_path, ": cannot create"));
  std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> context(ZSTD_createDCtx(), &ZSTD_freeDCtx);
  std::string in_buffer(ZSTD_DStreamInSize(), '\0');
  std::string out_buffer(ZSTD_DStreamOutSize(), '\0');
  size_t code = 0;
  bool any = false;
  while (true) {
    const size_t n = std::fread(in_buffer.data(), 1, in_buffer.size(), in.get());
    if (n == 0) break;
    any = true;
    ZSTD_inBuffer input{in_buffer.data(), n, 0};
    while (input.pos < input.size) {
      ZSTD_outBuffer output{out_buffer.data(), out_buffer.size(), 0};
      code = ZSTD_decompressStream(context.get(), &output, &input);
      if (ZSTD_isError(code)) {
        return absl::DataLossError(absl::StrCat(from_path, ": zstd: ", ZSTD_getErrorName(code)));
      }
      if (std::fwrite(out_buffer.data(), 1, output.pos, out.get()) != output.pos) {
        return absl::ResourceExhaustedError(absl::StrCat(to_path, ": write failed"));
      }
    }
  }
  if (!any || code != 0) return absl::DataLossError(absl::StrCat(from_path, ": zstd stream truncated"));
  return absl::OkStatus();
}

}  // namespace waymark::bags
