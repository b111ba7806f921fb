// The built-in prior: the bytes of assets/builtin_prior.pcpm, embedded at build time
// (cmake/PcpEmbed.cmake), read with the prior file reader.
#include "pcp/train/builtin_prior.hpp"

#include "pcp/nn/checkpoint.hpp"
#include "train/prior_io.hpp"

#include <string>

extern const unsigned char pcp_builtin_prior_bytes[];
extern const unsigned long pcp_builtin_prior_bytes_size;

namespace pcp {

const LocalPrior& builtin_prior() {
    static const LocalPrior prior = [] {
        const std::string name = "the built-in prior (assets/builtin_prior.pcpm)";
        const std::string bytes(reinterpret_cast<const char*>(pcp_builtin_prior_bytes), pcp_builtin_prior_bytes_size);
        return detail::prior_from_net_file(name, nn::parse_net_file<float>(name, bytes));
    }();
    return prior;
}

}  // namespace pcp
