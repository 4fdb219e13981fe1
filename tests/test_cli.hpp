// Running the `airmass` command line from a test: its standard output and exit status.
#pragma once

#include <cstdio>
#include <memory>
#include <string>

namespace airmass::test {

// Runs `cmd` through the shell (popen) and returns what it wrote on standard output;
// `status` receives pclose's status.
inline std::string run_command(const std::string& cmd, int& status) {
    std::string out;
    std::unique_ptr<FILE, int (*)(FILE*)> p(popen(cmd.c_str(), "r"), pclose);
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p.get())) > 0) out.append(buf, n);
    status = pclose(p.release());
    return out;
}

}  // namespace airmass::test
