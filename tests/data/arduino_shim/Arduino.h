// A tiny host stand-in for the Arduino core, enough to run firmware/arduino sketches on a PC
// (tests/integration/test_arduino_sketch.py). The simulated board is an Uno wired as
// firmware/arduino/README.md says; arduino_shim.cpp holds the simulated mat.
#pragma once

#include <stdint.h>

#define HIGH 1
#define LOW 0
#define INPUT 0
#define OUTPUT 1
#define A0 14
#define F(text) (text)

void pinMode(uint8_t pin, uint8_t mode);
void digitalWrite(uint8_t pin, uint8_t value);
int analogRead(uint8_t pin);
void delayMicroseconds(unsigned int us);
void delay(unsigned long ms);
unsigned long millis(void);

class HardwareSerial {
 public:
  void begin(long baud);
  void print(char c);
  void print(const char *text);
  void print(int value);
  void println(void);
  void println(const char *text);
};

extern HardwareSerial Serial;

void setup(void);
void loop(void);
