#include "core/npz.h"

#include <zlib.h>

#include <algorithm>
#include <bit>

#include "core/error.h"

namespace mr {

namespace {

void Put16(std::string* s, uint32_t v) {
  s->push_back(static_cast<char>(v & 0xff));
  s->push_back(static_cast<char>((v >> 8) & 0xff));
}
void Put32(std::string* s, uint32_t v) {
  Put16(s, v & 0xffff);
  Put16(s, v >> 16);
}

std::string Deflate(const std::string& in) {
  z_stream z{};
  // Raw deflate (no zlib header): what a ZIP entry of method 8 holds.
  if (deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    ThrowError("zlib: deflateInit2 failed");
  std::string out(deflateBound(&z, static_cast<uLong>(in.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) ThrowError("zlib: deflate failed ({})", rc);
  out.resize(z.total_out);
  return out;
}

}  // namespace

void NpzWriter::Add(const std::string& name, const std::string& descr, const std::vector<int64_t>& shape,
                    const std::string& data) {
  std::string tuple = "(";
  for (size_t i = 0; i < shape.size(); ++i) tuple += (i ? ", " : "") + std::to_string(shape[i]);
  tuple += shape.size() == 1 ? ",)" : ")";
  std::string header = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + tuple + ", }";
  // Format 1.0: magic, version, a 16-bit header length; the header padded
  // with spaces and ended by a newline so that the data starts at a
  // multiple of 64 bytes.
  const size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string npy("\x93NUMPY\x01\x00", 8);
  Put16(&npy, static_cast<uint32_t>(header.size()));
  npy += header;
  npy += data;
  entries_.push_back({name + ".npy", std::move(npy)});
}

void NpzWriter::AddF64(const std::string& name, std::vector<int64_t> shape, const std::vector<double>& v) {
  static_assert(std::endian::native == std::endian::little);
  Add(name, "<f8", shape, std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double)));
}

void NpzWriter::AddI32(const std::string& name, std::vector<int64_t> shape, const std::vector<int32_t>& v) {
  Add(name, "<i4", shape, std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(int32_t)));
}

void NpzWriter::AddScalar(const std::string& name, double v) { AddF64(name, {}, {v}); }

void NpzWriter::AddBool(const std::string& name, bool v) { Add(name, "|b1", {}, std::string(1, v ? '\1' : '\0')); }

void NpzWriter::AddString(const std::string& name, const std::string& ascii) {
  // numpy's unicode is UTF-32; an empty string is one NUL character.
  std::string data;
  for (char c : ascii) Put32(&data, static_cast<unsigned char>(c));
  if (ascii.empty()) Put32(&data, 0);
  Add(name, fmt::format("<U{}", std::max<size_t>(1, ascii.size())), {}, data);
}

std::string NpzWriter::Bytes() const {
  std::string zip, central;
  for (const Entry& e : entries_) {
    const uint32_t crc =
        static_cast<uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(e.npy.data()), static_cast<uInt>(e.npy.size())));
    const std::string packed = Deflate(e.npy);
    if (zip.size() + packed.size() > 0xffffffffu) ThrowError("npz archive over 4 GiB");
    const uint32_t offset = static_cast<uint32_t>(zip.size());
    // A fixed date (1980-01-01, 00:00): the same inputs give the same bytes.
    auto common = [&](std::string* s) {
      Put16(s, 20);  // version needed: deflate
      Put16(s, 0);   // flags
      Put16(s, 8);   // method: deflate
      Put16(s, 0);   // time
      Put16(s, 0x21);
      Put32(s, crc);
      Put32(s, static_cast<uint32_t>(packed.size()));
      Put32(s, static_cast<uint32_t>(e.npy.size()));
      Put16(s, static_cast<uint32_t>(e.name.size()));
      Put16(s, 0);  // extra field length
    };
    Put32(&zip, 0x04034b50);
    common(&zip);
    zip += e.name;
    zip += packed;
    Put32(&central, 0x02014b50);
    Put16(&central, 20);  // version made by
    common(&central);
    Put16(&central, 0);  // comment length
    Put16(&central, 0);  // disk
    Put16(&central, 0);  // internal attributes
    Put32(&central, 0);  // external attributes
    Put32(&central, offset);
    central += e.name;
  }
  const uint32_t cd_offset = static_cast<uint32_t>(zip.size());
  zip += central;
  Put32(&zip, 0x06054b50);
  Put16(&zip, 0);
  Put16(&zip, 0);
  Put16(&zip, static_cast<uint32_t>(entries_.size()));
  Put16(&zip, static_cast<uint32_t>(entries_.size()));
  Put32(&zip, static_cast<uint32_t>(central.size()));
  Put32(&zip, cd_offset);
  Put16(&zip, 0);
  return zip;
}

std::string Base85Encode(const std::string& bytes) {
  static const char kAlphabet[] =
      "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz!#$%&()*+-;<=>?@^_`{|}~";
  std::string out;
  out.reserve(bytes.size() / 4 * 5 + 5);
  for (size_t i = 0; i < bytes.size(); i += 4) {
    uint32_t word = 0;
    const size_t n = std::min<size_t>(4, bytes.size() - i);
    for (size_t k = 0; k < 4; ++k) word = (word << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    char group[5];
    for (int k = 4; k >= 0; --k) {
      group[k] = kAlphabet[word % 85];
      word /= 85;
    }
    out.append(group, n + 1);  // a short last group drops as many characters as it was padded
  }
  return out;
}

}  // namespace mr
