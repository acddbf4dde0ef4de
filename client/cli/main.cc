// waymark: the command line client. Everything but process setup lives in the waymark_cli library.
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <iostream>
#include <opencv2/core/utils/logger.hpp>

#include "client/cli/cli.h"

int main(int argc, char** argv) {
  // Output into a closed pipe (`waymark robot ... | tee log` with tee gone) fails quietly instead
  // of killing the command before it stops the robot and closes its session.
  std::signal(SIGPIPE, SIG_IGN);
  // OpenCV logs a warning for every backend it tries while opening a camera; the camera source
  // reports its own, clearer errors.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
  return waymark::cli::RunCli(argc, argv, std::cout, std::cerr, isatty(fileno(stderr)) != 0);
}
