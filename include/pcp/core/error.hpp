// pcp::Error and PCP_CHECK: the library's single error channel. Every failure that a caller can
// cause (bad file, bad option, degenerate input) throws pcp::Error with a message that names the
// file or option and the problem; the apps turn it into one line on stderr and a non-zero exit.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace pcp {

/// The exception thrown by libpcp for every caller-visible failure.
class Error : public std::runtime_error {
public:
    explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace pcp

/// Throw pcp::Error when `cond` is false. `msg` is a stream expression:
/// PCP_CHECK(n > 0, path << ": no points").
#define PCP_CHECK(cond, msg)                                                                       \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            std::ostringstream pcp_check_stream_;                                                  \
            pcp_check_stream_ << msg;                                                              \
            throw ::pcp::Error(pcp_check_stream_.str());                                           \
        }                                                                                          \
    } while (false)

/// Throw pcp::Error unconditionally with a stream-expression message.
#define PCP_FAIL(msg) PCP_CHECK(false, msg)
