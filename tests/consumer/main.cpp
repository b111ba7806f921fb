// Uses the installed libpcp through its public headers only; exits 0 when the calls work.
#include <pcp/pcp.hpp>

#include <iostream>

int main() {
    try {
        PCP_CHECK(false, "consumer: expected failure");
    } catch (const pcp::Error& e) {
        std::cout << "libpcp " << PCP_VERSION_STRING << " linked; error channel works: " << e.what() << "\n";
        return 0;
    }
    return 1;
}
