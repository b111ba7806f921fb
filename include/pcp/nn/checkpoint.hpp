// The versioned binary file format for networks and training state (".pcpn"). One file holds any
// number of named networks (BranchMlp or PointNet), each with its flat parameters and, optionally,
// its Adam moments and step count, plus the trainer's step. Files are written with
// pcp::write_file_atomically; loading rejects truncated files, bad checksums, foreign files (bad
// magic) and other format versions with a pcp::Error that names the file and the problem.
//
// Layout (little-endian, as written by the x86-64/ARM64 machines libpcp targets):
//   magic        8 bytes  "PCPNNET\n"
//   version      u32      kNetFileVersion
//   scalar bytes u32      4 (float) or 8 (double): how the parameter blocks are stored
//   payload size u64      bytes between this field and the checksum
//   payload:
//     step u64, reserved 4 x u64 (zero; an RNG state slot no trainer needs: every draw is
//     derived from the seed and the step), metadata (u64 length + bytes), network count u32, then per network:
//       name (u32 length + bytes), kind u32 (1 BranchMlp, 2 PointNet),
//       shape (u32 count + i32 values), parameter count u64, Adam step i64, has-Adam u8,
//       parameters, [Adam m, Adam v]   (scalars of the stored size)
//   checksum     u64      FNV-1a 64 of every byte before it
#pragma once

#include "pcp/core/hash.hpp"
#include "pcp/nn/adam.hpp"
#include "pcp/nn/networks.hpp"
#include "pcp/nn/rng.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace pcp::nn {

constexpr std::uint32_t kNetFileVersion = 1;

enum class NetKind : std::uint32_t { BranchMlp = 1, PointNet = 2 };

/// One network as stored: its kind and shape, flat parameters, optional Adam state.
template <class S>
struct NetRecord {
    std::string name;
    NetKind kind = NetKind::BranchMlp;
    std::vector<std::int32_t> shape;  ///< BranchMlp: in_a, in_b, width, depth, out;
                                      ///< PointNet: P+1, point widths, J+1, head widths
    Vec<S> params;
    bool has_adam = false;
    AdamState<S> adam;
};

/// The content of a file.
template <class S>
struct NetFile {
    std::uint64_t step = 0;
    std::string metadata;  ///< key=value lines (nn/metadata.hpp): a prior's settings, a checkpoint's fingerprint
    std::vector<NetRecord<S>> nets;

    /// The record called `name`; throws pcp::Error naming the missing network.
    const NetRecord<S>& get(const std::string& name) const;
};

template <class S>
NetRecord<S> make_record(const std::string& name, const BranchMlp<S>& net,
                         const AdamState<S>* adam = nullptr);
template <class S>
NetRecord<S> make_record(const std::string& name, const PointNet<S>& net,
                         const AdamState<S>* adam = nullptr);

/// The network stored in a record (throws pcp::Error if the kind or sizes do not fit).
template <class S>
BranchMlp<S> to_branch_mlp(const NetRecord<S>& rec);
template <class S>
PointNet<S> to_pointnet(const NetRecord<S>& rec);

/// Writes `file` to `path` atomically, storing scalars as S.
template <class S>
void save_net_file(const std::string& path, const NetFile<S>& file);

/// Reads `path`; parameters stored as float or double are converted to S.
template <class S>
NetFile<S> load_net_file(const std::string& path);

/// Parses the bytes of a network file (`path` only names it in errors): the checks and results of
/// load_net_file. Every malformed input is a pcp::Error (fuzzed: tests/fuzz/fuzz_netfile.cpp).
template <class S>
NetFile<S> parse_net_file(const std::string& path, const std::string& bytes);

using pcp::fnv1a64;  ///< the file checksum (pcp/core/hash.hpp)

}  // namespace pcp::nn
