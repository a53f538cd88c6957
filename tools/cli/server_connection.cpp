// --server / --timeout handling and error reports of the daemon's commands.
#include "server_connection.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

namespace rbdgrad::cli {

std::string make_client(const Args& args, std::unique_ptr<Client>& out) {
  ClientOptions options;
  if (const std::string* t = args.value("timeout")) {
    double seconds = 0;
    const auto [end, ec] = std::from_chars(t->data(), t->data() + t->size(), seconds);
    if (ec != std::errc() || end != t->data() + t->size() || !std::isfinite(seconds) || seconds <= 0 || seconds > 1e6)
      return "--timeout: '" + *t + "' is not a positive number of seconds";
    options.default_timeout = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::duration<double>(seconds));
  }
  if (const std::string* path = args.value("token-file")) {
    std::ifstream in(*path);
    if (!in) return "--token-file: cannot read '" + *path + "'";
    // the token is the file's one word: a trailing newline or spaces are not part of it
    std::string token, extra;
    in >> token;
    if (token.empty()) return "--token-file: '" + *path + "' is empty";
    if (in >> extra) return "--token-file: '" + *path + "' holds more than one word (the token alone, please)";
    options.bearer_token = token;
  }
  if (args.has("tls-ca") || args.has("tls-cert") || args.has("tls-key")) {
    if (args.has("tls-cert") != args.has("tls-key")) return "--tls-cert and --tls-key go together";
    TlsOptions tls;
    tls.ca_file = args.value_or("tls-ca", "");
    tls.cert_file = args.value_or("tls-cert", "");
    tls.key_file = args.value_or("tls-key", "");
    options.tls = tls;
  }
  const std::string address = args.value_or("server", kDefaultServerAddress);
  if (address.empty()) return "--server: empty address";
  try {
    out = std::make_unique<Client>(address, options);
  } catch (const ClientError& e) {
    // a TLS file that cannot be read: "client: tls.ca_file: cannot read 'x'"
    std::string message = e.message();
    if (message.rfind("client: ", 0) == 0) message.erase(0, 8);
    return message;
  }
  return "";
}

int report_rpc_failure(std::string_view command, const Client& client, const RpcStatus& status) {
  std::cerr << "rbdgrad " << command << ": " << status.to_string() << " (server " << client.address() << ")\n";
  return 1;
}

}  // namespace rbdgrad::cli
