// psmat_csv_16x16.ino - a do-it-yourself 16x16 Velostat mat on an Arduino Uno / Nano
// (ATmega328P, 10-bit ADC, 5 V), speaking psmat's csv protocol (docs/protocol.md, "csv").
//
// The circuit is the basic reading circuit of docs/spec.md §2:
//   row i    -> row multiplexer (CD74HC4067, channel i)    -> common pin = node X
//   node X   -> R_o = 2.2 kOhm -> 5 V,  and node X -> A0
//   column p -> column multiplexer (CD74HC4067, channel p) -> common pin = GND
// so A0 reads V_x = 5 V * R_x / (R_o + R_x), R_x the cell's path to ground: an unloaded cell
// reads near 1023, a loaded one lower. Wiring table: firmware/arduino/README.md.
//
// Output, 115200 Bd: a header line (it starts with '#': psmat skips it), then one frame per
// line, 256 counts row-major (row 0 column 0 first, then row 0 column 1, ...), separated by
// commas, each line ended by "\r\n" (Serial.println). The sketch reads no input: psmat
// sends it no commands. Record it with
//   psmat record /dev/ttyUSB0 --protocol csv --shape 16x16 --bits 10 --seconds 60 -o mat.h5

const uint8_t ROWS = 16;
const uint8_t COLS = 16;
// select lines S0..S3 (S0 = bit 0 of the channel number) of each multiplexer
const uint8_t ROW_SELECT[4] = {2, 3, 4, 5};   // row mux S0, S1, S2, S3 on D2..D5
const uint8_t COL_SELECT[4] = {6, 7, 8, 9};   // column mux S0, S1, S2, S3 on D6..D9
const uint8_t ADC_PIN = A0;                   // node X
const unsigned int SETTLE_US = 30;            // after a channel change, before analogRead (mux + R_o * C)
const unsigned long PERIOD_MS = 100;          // at most 10 frames/s (the link allows about 9 when
                                              // every count has four digits: 1280 bytes a frame)

// Put channel `ch` (0..15) on a multiplexer's four select lines, S0 = bit 0.
static void selectChannel(const uint8_t pins[4], uint8_t ch) {
  for (uint8_t b = 0; b < 4; b++) {
    digitalWrite(pins[b], ((ch >> b) & 1) ? HIGH : LOW);
  }
}

void setup() {
  Serial.begin(115200);
  for (uint8_t b = 0; b < 4; b++) {
    pinMode(ROW_SELECT[b], OUTPUT);
    pinMode(COL_SELECT[b], OUTPUT);
  }
  Serial.println(F("# psmat csv 16x16 10-bit, one frame per line, row-major"));
}

void loop() {
  unsigned long start = millis();
  for (uint8_t i = 0; i < ROWS; i++) {
    selectChannel(ROW_SELECT, i);
    for (uint8_t p = 0; p < COLS; p++) {
      selectChannel(COL_SELECT, p);
      delayMicroseconds(SETTLE_US);
      int count = analogRead(ADC_PIN);
      if (i != 0 || p != 0) {
        Serial.print(',');
      }
      Serial.print(count);
    }
  }
  Serial.println();
  while (millis() - start < PERIOD_MS) {
    // wait for the next frame time
  }
}
