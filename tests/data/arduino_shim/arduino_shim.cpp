// Host stand-in for an Arduino Uno reading a simulated 16x16 mat (tests/integration/test_arduino_sketch.py).
//
// The board is wired as firmware/arduino/README.md says, written here once:
//   row mux S0..S3 = D2..D5, column mux S0..S3 = D6..D9 (S0 = bit 0 of the channel),
//   row mux channel i = mat row i, column mux channel p = mat column p, node X = A0.
// analogRead(A0) returns the count of the cell the two multiplexers select, taken from a
// (16, 16) array of counts read from a text file. It fails (exit 2, a line on stderr) when the
// sketch reads before the lines settled (no delayMicroseconds >= 10 since the last select
// change), writes a pin it did not make an output, or reads another pin. Time is simulated:
// microseconds advance with delays, conversions (about 112 us) and serial bytes (10 bits at
// the baud rate), so millis() moves as on the board.
//
// usage: shim MAT.txt LOOPS   (256 integers, row-major) -> the sketch's serial output on stdout

#include "Arduino.h"

#include <cstdio>
#include <cstdlib>

HardwareSerial Serial;

namespace {

const int kRowSelect[4] = {2, 3, 4, 5};
const int kColSelect[4] = {6, 7, 8, 9};
const unsigned int kSettleUs = 10;

int g_mat[16][16];
uint8_t g_level[20];
bool g_output[20];
bool g_settled = false;
long g_baud = 0;
double g_us = 0.0;

void fail(const char *what, int pin) {
  std::fprintf(stderr, "arduino shim: %s (pin %d)\n", what, pin);
  std::exit(2);
}

bool isSelect(uint8_t pin) {
  for (int b = 0; b < 4; b++) {
    if (pin == kRowSelect[b] || pin == kColSelect[b]) return true;
  }
  return false;
}

int address(const int pins[4]) {
  int a = 0;
  for (int b = 0; b < 4; b++) a |= (g_level[pins[b]] ? 1 : 0) << b;
  return a;
}

void sent(int bytes) {
  if (g_baud <= 0) fail("Serial used before Serial.begin", -1);
  g_us += bytes * 10.0 * 1e6 / static_cast<double>(g_baud);
}

}  // namespace

void pinMode(uint8_t pin, uint8_t mode) {
  if (pin >= 20) fail("no such pin", pin);
  g_output[pin] = (mode == OUTPUT);
}

void digitalWrite(uint8_t pin, uint8_t value) {
  if (pin >= 20 || !g_output[pin]) fail("digitalWrite on a pin that is not an output", pin);
  if (g_level[pin] != (value ? 1 : 0) && isSelect(pin)) g_settled = false;
  g_level[pin] = value ? 1 : 0;
  g_us += 4.0;
}

int analogRead(uint8_t pin) {
  if (pin != A0) fail("analogRead of a pin that is not node X (A0)", pin);
  if (!g_settled) fail("analogRead before the multiplexers settled", pin);
  g_us += 112.0;
  return g_mat[address(kRowSelect)][address(kColSelect)];
}

void delayMicroseconds(unsigned int us) {
  if (us >= kSettleUs) g_settled = true;
  g_us += us;
}

void delay(unsigned long ms) { g_us += 1000.0 * ms; }

unsigned long millis(void) {
  g_us += 1.0;  // a busy-wait on millis() moves on
  return static_cast<unsigned long>(g_us / 1000.0);
}

void HardwareSerial::begin(long baud) { g_baud = baud; }

void HardwareSerial::print(char c) {
  sent(1);
  std::putchar(c);
}

void HardwareSerial::print(const char *text) {
  int n = std::printf("%s", text);
  sent(n);
}

void HardwareSerial::print(int value) {
  int n = std::printf("%d", value);
  sent(n);
}

void HardwareSerial::println(void) {
  sent(2);
  std::fputs("\r\n", stdout);
}

void HardwareSerial::println(const char *text) {
  print(text);
  println();
}

int main(int argc, char **argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s MAT.txt LOOPS\n", argv[0]);
    return 2;
  }
  std::FILE *f = std::fopen(argv[1], "r");
  if (!f) {
    std::fprintf(stderr, "arduino shim: cannot open %s\n", argv[1]);
    return 2;
  }
  for (int i = 0; i < 16; i++) {
    for (int p = 0; p < 16; p++) {
      if (std::fscanf(f, "%d", &g_mat[i][p]) != 1) {
        std::fprintf(stderr, "arduino shim: %s holds fewer than 256 counts\n", argv[1]);
        return 2;
      }
    }
  }
  std::fclose(f);
  long loops = std::atol(argv[2]);
  setup();
  for (long k = 0; k < loops; k++) loop();
  std::fflush(stdout);
  std::fprintf(stderr, "baud=%ld us=%.0f\n", g_baud, g_us);
  return 0;
}
