# Every dependency comes from Debian 12 packages (scripts/install-deps.sh); nothing is downloaded.
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(urdfdom REQUIRED)          # liburdfdom-dev: URDF parsing
find_package(console_bridge REQUIRED)   # urdfdom's logging: we capture its parse errors
find_package(nlohmann_json 3 REQUIRED)  # nlohmann-json3-dev: JSON Lines state files
find_package(Threads REQUIRED)
find_package(Protobuf REQUIRED)         # libprotobuf-dev, protobuf-compiler: the service API messages
find_package(gRPC CONFIG REQUIRED)      # libgrpc++-dev, protobuf-compiler-grpc: the service
if(RBDGRAD_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(RBDGRAD_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
