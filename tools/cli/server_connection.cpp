// --server / --timeout handling and error reports of the daemon's commands.
#include "server_connection.hpp"

#include <charconv>
#include <cmath>
#include <iostream>

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
  const std::string address = args.value_or("server", kDefaultServerAddress);
  if (address.empty()) return "--server: empty address";
  out = std::make_unique<Client>(address, options);
  return "";
}

int report_rpc_failure(std::string_view command, const Client& client, const RpcStatus& status) {
  std::cerr << "rbdgrad " << command << ": " << status.to_string() << " (server " << client.address() << ")\n";
  return 1;
}

}  // namespace rbdgrad::cli
