// waymark: the command line client. Everything but process setup lives in the waymark_cli library.
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <opencv2/core/utils/logger.hpp>

#include "client/cli/cli.h"

int main(int argc, char** argv) {
  // OpenCV logs a warning for every backend it tries while opening a camera; the camera source
  // reports its own, clearer errors.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
  return waymark::cli::RunCli(argc, argv, std::cout, std::cerr, isatty(fileno(stderr)) != 0);
}
