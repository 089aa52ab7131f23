"""USART1 of the STM32F103: asynchronous 8N1 at PCLK2 / BRR (RM0008 §27).

Modelled: SR (TXE, TC, RXNE, ORE), DR, BRR, CR1 (UE, TE, RE, RXNEIE, TCIE, TXEIE); CR2 and CR3
must stay 0 (one stop bit, no flow control, no DMA). The baud rate is PCLK2 / USARTDIV / 16 =
PCLK2 / BRR, BRR being DIV_Mantissa << 4 | DIV_Fraction (RM0008 §27.3.4); a frame is 10 bit times
(start, 8 data, stop).

Transmission: a byte written to DR (the TDR) moves to the shift register at once when it is idle,
which sets TXE again; otherwise it waits there (TXE = 0) until the byte being shifted ends. A byte
is complete (appended to ``tx`` with its time in ``tx_times_s``) one frame after it entered the
shift register; TC is set when a byte completes with the TDR empty, and cleared by a write of DR or
of 0 to TC. Setting TE sends an idle frame first (RM0008 §27.3.2): the shift register is busy for
one frame. Reception: :meth:`Usart1.feed` schedules host bytes back to back, one per frame at the
configured baud; at the end of each, RXNE is set with the byte in the RDR, or, when RXNE is
still set, ORE is set and the byte is lost. Reading DR clears RXNE and ORE. IRQ 37 is pended
whenever TXEIE & TXE, TCIE & TC, or RXNEIE & (RXNE | ORE) holds after a change.

Misuse caught here: writing DR with UE or TE off, or while TXE = 0 (the waiting byte would be
overwritten); a BRR below 16 (USARTDIV < 1) when transmitting or receiving.
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING

from ._registers import RegisterModel, due

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ._machine import Machine

__all__ = ["Usart1"]

SR, DR, BRR, CR1, CR2, CR3, GTPR = range(0, 0x1C, 4)
ORE, RXNE, TC, TXE = 1 << 3, 1 << 5, 1 << 6, 1 << 7
RE, TE, RXNEIE, TCIE, TXEIE, UE = 1 << 2, 1 << 3, 1 << 5, 1 << 6, 1 << 7, 1 << 13
_CR1_MODELLED = RE | TE | RXNEIE | TCIE | TXEIE | UE
BITS_PER_FRAME = 10  # start, 8 data bits, 1 stop bit
IRQ = 37


class Usart1(RegisterModel):
    """USART1 at 0x40013800, IRQ 37 (clock RCC.APB2ENR.USART1EN).

    Attributes
    ----------
    tx : bytearray
        Every byte sent since power-up.
    tx_times_s : list of float
        Emulated time (s) at which each byte of ``tx`` ended (its stop bit).
    rx_lost : int
        Host bytes that arrived while the receiver was off (UE or RE = 0).
    overruns : int
        Host bytes lost to an overrun (ORE).
    """

    name = clock = "USART1"
    base = 0x40013800
    halfword_writes = True
    irq = IRQ

    def __init__(self, machine: Machine) -> None:
        self.tx = bytearray()
        self.tx_times_s: list[float] = []
        self.rx_lost = 0
        self.overruns = 0
        self._rx_queue: deque[tuple[float, int]] = deque()  # (end of frame s, byte)
        self._rx_free_s = 0.0  # when the host's line is free for the next fed byte
        super().__init__(machine)

    def reset(self) -> None:
        """SR = TXE | TC, every other register 0, line idle."""
        self.sr = TXE | TC
        self.brr = self.cr1 = 0
        self.rdr = 0
        self.tdr: int | None = None           # byte waiting in the TDR
        self.shifting: int | None = None      # byte in the shift register (-1: idle frame)
        self.shift_end_s: float | None = None

    # -- time ----------------------------------------------------------------------------------

    def frame_time_s(self) -> float:
        """Duration (s) of one frame (10 bits) at the configured baud rate."""
        if self.brr < 16:
            self.misuse(f"BRR = {self.brr} (USARTDIV < 1): the baud rate is not set")
        return BITS_PER_FRAME * self.brr / self.machine.rcc.clock_hz("PCLK2")

    def baud(self) -> float:
        """The configured baud rate (bit/s): PCLK2 / BRR."""
        return BITS_PER_FRAME / self.frame_time_s()

    def next_event_s(self) -> float | None:
        """The end of the frame being shifted out or of the next host byte."""
        ends = [t for t in (self.shift_end_s, self._rx_queue[0][0] if self._rx_queue else None)
                if t is not None]
        return min(ends) if ends else None

    def advance(self, now_s: float) -> None:
        """Completes the frames (both ways) that end by ``now_s``, in time order."""
        changed = False
        while True:
            tx_end = self.shift_end_s if due(self.shift_end_s, now_s) else None
            rx_end = self._rx_queue[0][0] if self._rx_queue and due(self._rx_queue[0][0], now_s) else None
            if tx_end is None and rx_end is None:
                break
            changed = True
            if rx_end is not None and (tx_end is None or rx_end <= tx_end):
                self._receive(*self._rx_queue.popleft())
            else:
                self._shift_done(tx_end)
        if changed:
            self._irq()

    def _shift_done(self, end_s: float) -> None:
        if self.shifting is not None and self.shifting >= 0:
            self.tx.append(self.shifting)
            self.tx_times_s.append(end_s)
        self.shifting = self.shift_end_s = None
        if self.tdr is not None:
            self._load_shifter(end_s)
        else:
            self.sr |= TC

    def _load_shifter(self, start_s: float) -> None:
        self.shifting, self.tdr = self.tdr, None
        self.shift_end_s = start_s + self.frame_time_s()
        self.sr |= TXE

    def _receive(self, _end_s: float, byte: int) -> None:
        if not (self.cr1 & UE and self.cr1 & RE):
            self.rx_lost += 1
        elif self.sr & RXNE:
            self.sr |= ORE
            self.overruns += 1
        else:
            self.rdr = byte
            self.sr |= RXNE

    def _irq(self) -> None:
        sr, cr1 = self.sr, self.cr1
        if ((cr1 & TXEIE and sr & TXE) or (cr1 & TCIE and sr & TC)
                or (cr1 & RXNEIE and sr & (RXNE | ORE))):
            self.machine.nvic.set_pending(IRQ)

    # -- the host's side ---------------------------------------------------------------------------

    def feed(self, data: bytes, at_s: float | None = None) -> None:
        """Sends ``data`` from the host: the first byte starts at ``at_s`` (s; default now, or
        when the previously fed bytes are through), each further byte one frame later."""
        if self.brr < 16:
            raise ValueError(f"USART1: BRR = {self.brr}, the baud rate is not set yet: feed host "
                             f"bytes once the firmware has configured the USART")
        frame = self.frame_time_s()
        start = max(self.machine.now_s if at_s is None else float(at_s), self._rx_free_s)
        for byte in bytes(data):
            start += frame
            self._rx_queue.append((start, byte))
        self._rx_free_s = start

    # -- registers -------------------------------------------------------------------------------

    def read_register(self, offset: int) -> int:
        """SR, DR (clears RXNE and ORE), BRR, CR1, CR2, CR3."""
        if offset == DR:
            self.sr &= ~(RXNE | ORE)
            return self.rdr
        regs = {SR: self.sr, BRR: self.brr, CR1: self.cr1, CR2: 0, CR3: 0}
        if offset in regs:
            return regs[offset]
        self._no_register(offset)

    def write_register(self, offset: int, value: int) -> None:
        """Writes one register with the checks of the module docstring."""
        if offset == SR:
            self.sr &= value | ~(RXNE | TC)  # rc_w0 on RXNE and TC; the other flags read-only
        elif offset == DR:
            self._write_dr(value)
        elif offset == BRR:
            if value >> 16:
                self.misuse(f"BRR reserved bits 31:16 written: 0x{value:08X}")
            if self.shifting is not None or self.tdr is not None or self._rx_queue:
                self.unmodelled(BRR, "changing BRR while a frame is on the line is not modelled")
            self.brr = value
        elif offset == CR1:
            self._write_cr1(value)
        elif offset in (CR2, CR3):
            if value:
                reg = "CR2" if offset == CR2 else "CR3"
                self.unmodelled(offset, f"{reg} = 0x{value:08X} not modelled (1 stop bit, no "
                                        f"clock, LIN, flow control, DMA)")
        else:
            self._no_register(offset)
        self._irq()

    def _no_register(self, offset: int) -> None:
        self.unmodelled(offset, "USART1.GTPR not modelled" if offset == GTPR else "reserved offset")

    def _write_cr1(self, value: int) -> None:
        if value & ~_CR1_MODELLED:
            self.unmodelled(CR1, f"CR1 bits 0x{value & ~_CR1_MODELLED:04X} not modelled (parity, "
                                 f"9-bit words, wake-up, break, IDLE/PE interrupts)")
        old = self.cr1
        busy = self.shifting is not None or self.tdr is not None
        if busy and not (value & UE and value & TE):
            self.unmodelled(CR1, "UE or TE cleared while a frame is being sent is not modelled")
        self.cr1 = value
        if value & UE and value & TE and not (old & UE and old & TE):
            self.shifting = -1  # the idle frame
            self.shift_end_s = self.machine.now_s + self.frame_time_s()

    def _write_dr(self, value: int) -> None:
        if not self.cr1 & UE:
            self.misuse("DR written while CR1.UE = 0 (USART disabled)")
        if not self.cr1 & TE:
            self.misuse("DR written while CR1.TE = 0 (transmitter disabled)")
        if not self.sr & TXE:
            self.misuse(f"DR written while TXE = 0: byte 0x{self.tdr or 0:02X} still waiting in "
                        f"the TDR would be lost")
        if value & ~0x1FF:
            self.misuse(f"DR reserved bits written: 0x{value:08X}")
        self.tdr = value & 0xFF
        self.sr &= ~(TXE | TC)
        if self.shifting is None:
            self._load_shifter(self.machine.now_s)
