// The entry point of remote `pf` (`pf --server ADDR ...` or PF_SERVER set):
// dispatches to the scene, render and jobs command groups and turns their
// errors into messages and exit codes.
#ifndef POINTFORWARD_CLIENT_REMOTE_REMOTE_MAIN_H_
#define POINTFORWARD_CLIENT_REMOTE_REMOTE_MAIN_H_

#include <optional>
#include <string>
#include <vector>

namespace pf {

// The commands RunRemote accepts; `pf` sends these to the server when
// PF_SERVER is set.
bool IsRemoteCommand(const std::string& command);

// Runs `args` (command first, e.g. {"scene", "list"}, after any of the
// connection flags --tls-ca PEM, --tls-cert PEM, --tls-key PEM and
// --token-file PATH; the token otherwise comes from PF_TOKEN) against the
// server at `address` and returns the exit code: 0 done, 1 job failed or
// cancelled, 2 bad input, 3 server unreachable ("pf: server ADDR
// unreachable: ...").
int RunRemote(const std::string& address, const std::vector<std::string>& args);

// Runs `words` (argv without the program name) remotely when they ask for
// it: a leading "--server ADDR" or "--server=ADDR", or PF_SERVER set and a
// remote command first. Returns the exit code, or nullopt for embedded mode.
std::optional<int> RunRemoteIfAsked(const std::vector<std::string>& words);

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_REMOTE_REMOTE_MAIN_H_
