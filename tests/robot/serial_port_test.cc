#include "client/devices/serial_port.h"

#include <gtest/gtest.h>

#include "tests/robot/pty_pair.h"

namespace waymark::adapters {
namespace {

using testing::PtyPair;

std::vector<std::uint8_t> ReadAll(SerialPort& port, std::size_t want) {
  std::vector<std::uint8_t> out;
  std::uint8_t buffer[256];
  for (int i = 0; i < 50 && out.size() < want; ++i) {
    auto n = port.Read(buffer, sizeof(buffer), absl::Milliseconds(20));
    if (!n.ok()) break;
    out.insert(out.end(), buffer, buffer + *n);
  }
  return out;
}

TEST(SerialPortTest, BytesGoBothWaysUnchanged) {
  auto pty = PtyPair::Open();
  ASSERT_TRUE(pty.ok()) << pty.status();
  auto port = SerialPort::Open(pty->device_path(), 9600);
  ASSERT_TRUE(port.ok()) << port.status();
  // Bytes a line discipline would eat or translate: CR, LF, XON/XOFF, ^C, 0xFF.
  const std::vector<std::uint8_t> out = {0x0D, 0x0A, 0x11, 0x13, 0x03, 0xFF, 0x00, 0xFA};
  ASSERT_TRUE((*port)->Write(out).ok());
  std::vector<std::uint8_t> seen;
  for (int i = 0; i < 20 && seen.size() < out.size(); ++i) {
    auto chunk = pty->ReadSome(absl::Milliseconds(50));
    seen.insert(seen.end(), chunk.begin(), chunk.end());
  }
  EXPECT_EQ(seen, out);
  ASSERT_TRUE(pty->Write(out));
  EXPECT_EQ(ReadAll(**port, out.size()), out);
}

TEST(SerialPortTest, ReadTimesOutWithZeroBytes) {
  auto pty = PtyPair::Open();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::Open(pty->device_path(), 9600);
  ASSERT_TRUE(port.ok());
  std::uint8_t buffer[8];
  auto n = (*port)->Read(buffer, sizeof(buffer), absl::Milliseconds(10));
  ASSERT_TRUE(n.ok()) << n.status();
  EXPECT_EQ(*n, 0u);
}

TEST(SerialPortTest, BaudChangesAreVisibleOnTheLine) {
  auto pty = PtyPair::Open();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::Open(pty->device_path(), 9600);
  ASSERT_TRUE(port.ok());
  EXPECT_EQ(pty->host_baud(), 9600);
  ASSERT_TRUE((*port)->SetBaud(38400).ok());
  EXPECT_EQ(pty->host_baud(), 38400);
  EXPECT_EQ((*port)->baud(), 38400);
  EXPECT_EQ((*port)->SetBaud(12345).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ((*port)->baud(), 38400);
}

TEST(SerialPortTest, UnpluggedDeviceIsUnavailable) {
  auto pty = PtyPair::Open();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::Open(pty->device_path(), 9600);
  ASSERT_TRUE(port.ok());
  pty->Hangup();
  std::uint8_t buffer[8];
  auto n = (*port)->Read(buffer, sizeof(buffer), absl::Milliseconds(100));
  ASSERT_FALSE(n.ok());
  EXPECT_EQ(n.status().code(), absl::StatusCode::kUnavailable) << n.status();
  EXPECT_NE(n.status().message().find("disconnected"), std::string::npos) << n.status();
}

TEST(SerialPortTest, OpenErrorsNameTheDevice) {
  auto missing = SerialPort::Open("/dev/ttyWAYMARK_missing", 9600);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("/dev/ttyWAYMARK_missing"), std::string::npos);
  auto not_a_tty = SerialPort::Open("/dev/null", 9600);
  ASSERT_FALSE(not_a_tty.ok());
  EXPECT_NE(not_a_tty.status().message().find("/dev/null"), std::string::npos);
  auto pty = PtyPair::Open();
  ASSERT_TRUE(pty.ok());
  EXPECT_EQ(SerialPort::Open(pty->device_path(), 1234).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace waymark::adapters
