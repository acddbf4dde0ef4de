#include "server/service/runtime/server_channel.h"

#include <grpcpp/resource_quota.h>

namespace waymark::service {
namespace {

int Millis(absl::Duration d) { return static_cast<int>(absl::ToInt64Milliseconds(d)); }

}  // namespace

void ConfigureServerChannel(grpc::ServerBuilder* builder, const ServerChannelOptions& options) {
  builder->AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, Millis(kServerKeepaliveTime));
  builder->AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, Millis(kServerKeepaliveTimeout));
  builder->AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  builder->AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS,
                              Millis(kMinClientPingInterval));
  builder->AddChannelArgument(GRPC_ARG_HTTP2_MAX_PING_STRIKES, 0);  // 0 = never GOAWAY for pings
  // The server's own keepalive pings go out on idle connections too.
  builder->AddChannelArgument(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  const int max_bytes = options.max_message_mb * 1024 * 1024;
  builder->SetMaxReceiveMessageSize(max_bytes);
  builder->SetMaxSendMessageSize(max_bytes);
  if (options.threads > 0) {
    grpc::ResourceQuota quota("waymark");
    quota.SetMaxThreads(options.threads);
    builder->SetResourceQuota(quota);
  }
}

}  // namespace waymark::service
