// NumPy's .npz archive (a ZIP of .npy arrays, deflated as numpy's
// savez_compressed does) and Python's base-85 text encoding: together, what
// mrcal stores as a .cameramodel's 'optimization_inputs'.  Written only.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace mr {

class NpzWriter {
 public:
  // Arrays in C order; `shape` empty for a scalar.
  void AddF64(const std::string& name, std::vector<int64_t> shape, const std::vector<double>& v);
  void AddI32(const std::string& name, std::vector<int64_t> shape, const std::vector<int32_t>& v);
  void AddScalar(const std::string& name, double v);
  void AddBool(const std::string& name, bool v);
  // A scalar unicode string ('<U' numpy dtype); "" is how mrcal stores None.
  void AddString(const std::string& name, const std::string& ascii);
  // The archive's bytes.
  std::string Bytes() const;

 private:
  void Add(const std::string& name, const std::string& descr, const std::vector<int64_t>& shape,
           const std::string& data);
  struct Entry {
    std::string name, npy;
  };
  std::vector<Entry> entries_;
};

// Python's base64.b85encode (RFC 1924 alphabet, the last group shortened).
std::string Base85Encode(const std::string& bytes);

}  // namespace mr
