// pcp_reconstruct: command-line entry point (skeleton until its module lands).
#include "cli_common.hpp"

int main(int argc, char** argv) {
    return pcp::cli::run_main("pcp_reconstruct", [&] {
        cxxopts::Options options("pcp_reconstruct", "libpcp");
        pcp::cli::add_common_options(options);
        cxxopts::ParseResult args;
        pcp::cli::CommonFlags common;
        if (!pcp::cli::parse_command_line(options, argc, argv, args, common)) return 0;
        return 0;
    });
}
