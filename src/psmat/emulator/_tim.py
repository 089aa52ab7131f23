"""TIM2/TIM3/TIM4, the general-purpose timers of the STM32F103, up-counting (RM0008 §15).

Modelled: CR1 (CEN, UDIS, URS, ARPE), CR2 (MMS = reset or update), SMCR (SMS = internal clock,
or external clock mode 1 from an internal trigger, RM0008 §15.3.15), DIER (UIE), SR (UIF, TIF;
rc_w0), EGR (UG), CNT, PSC and ARR with their preload/shadow behaviour (PSC, and ARR when ARPE,
load at an update event). Capture/compare, DMA, down- and centre-aligned counting, one-pulse mode
and the other slave modes fail as unmodelled.

Counting is computed lazily from the emulated time: the timer clock is RCC's TIMCLK1 (the three
are on APB1) and the counter advances by whole clock periods since time 0. The prescaler counts
from the tick at which CEN is written (the one-clock start-up delay of RM0008 Figure 100 is not
modelled). An update event (counter overflow at ARR, or UG) loads the shadow registers, sets UIF
(unless UDIS; an UG with URS sets no UIF), pends the timer's IRQ when UIE, and gives a TRGO pulse
when MMS = update (MMS = reset: only UG gives one). A slave in external clock mode 1 counts the
master's TRGO pulses (ITRx per RM0008 Table 86). A counter above ARR (ARR lowered with ARPE = 0)
counts on to 0xFFFF and wraps to 0 without an update event. With ARR = 0 the counter is blocked.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ._registers import RegisterModel, ticks_at

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ._machine import Machine

__all__ = ["Tim2", "Tim3", "Tim4", "Timer"]

CR1, CR2, SMCR, DIER, SR, EGR, CCMR1, CCMR2, CCER, CNT, PSC, ARR = range(0, 0x30, 4)
_UNMODELLED = {CCMR1: "CCMR1", CCMR2: "CCMR2", CCER: "CCER", 0x34: "CCR1", 0x38: "CCR2",
               0x3C: "CCR3", 0x40: "CCR4", 0x48: "DCR", 0x4C: "DMAR"}
CEN, UDIS, URS, OPM, DIR, ARPE = 1 << 0, 1 << 1, 1 << 2, 1 << 3, 1 << 4, 1 << 7
UIF, TIF = 1 << 0, 1 << 6
UIE = 1 << 0
UG = 1 << 0
SMS_EXTERNAL_1 = 7
MMS_RESET, MMS_UPDATE = 0, 2


class Timer(RegisterModel):
    """One general-purpose timer; :class:`Tim2`, :class:`Tim3`, :class:`Tim4` place it.

    Attributes
    ----------
    trgo_count : int
        TRGO pulses given since reset (a slave counts their increase).
    updates : int
        Update events since reset (overflows and UG, whether or not UIF was set).
    """

    irq = 0
    halfword_writes = True
    itr: dict[int, str] = {}  # TS value -> master timer (RM0008 Table 86)

    def __init__(self, machine: Machine) -> None:
        self._now_s = 0.0
        self._tick = 0
        super().__init__(machine)

    def reset(self) -> None:
        """All registers 0 except ARR = 0xFFFF (RM0008 §15.4)."""
        self.cr1 = self.cr2 = self.smcr = self.dier = self.sr = 0
        self.cnt = 0
        self.psc = self.psc_active = 0
        self.arr = self.arr_active = 0xFFFF
        self.psc_count = 0          # prescaler counter, 0..psc_active
        self.trgo_count = 0
        self.updates = 0
        self._master_seen = 0       # master's trgo_count at the last advance (slave mode)

    # -- time ------------------------------------------------------------------------------

    def _clock_hz(self) -> float:
        return self.machine.rcc.clock_hz("TIMCLK1")

    def _slave(self) -> bool:
        return (self.smcr & 7) == SMS_EXTERNAL_1

    def _master(self) -> Timer:
        master = self.machine.peripheral(self.itr[self.smcr >> 4 & 7])
        if master._slave():
            self.unmodelled(SMCR, f"{self.name} clocked by {master.name}, itself a slave: "
                                  f"cascaded slaves not modelled")
        return master

    def advance(self, now_s: float) -> None:
        """Counts the clock periods (or, in slave mode, the master's TRGO pulses) up to ``now_s``."""
        if now_s < self._now_s:
            return
        self._now_s = now_s
        tick = ticks_at(now_s, self._clock_hz())
        elapsed, self._tick = tick - self._tick, tick
        if self._slave():
            master = self._master()
            master.advance(now_s)
            edges, self._master_seen = master.trgo_count - self._master_seen, master.trgo_count
            if edges and self.cr1 & CEN:
                self.sr |= TIF
                self._count(edges)
        elif self.cr1 & CEN and elapsed > 0:
            self._count(elapsed)

    def _to_update(self) -> int | None:
        """Clock pulses from the current state to the next overflow at ARR, None if blocked."""
        if self.arr_active == 0:
            return None
        p = self.psc_active + 1
        if self.cnt > self.arr_active:  # wraps at 0xFFFF first, then counts to ARR
            return p * (0x10000 - self.cnt + self.arr_active + 1) - self.psc_count
        return p * (self.arr_active - self.cnt + 1) - self.psc_count

    def _count(self, n: int) -> None:
        while n > 0 and self.arr_active:
            p = self.psc_active + 1
            above = self.cnt > self.arr_active
            steps = 0x10000 - self.cnt if above else self.arr_active - self.cnt + 1
            to_event = p * steps - self.psc_count
            if n < to_event:
                total = self.psc_count + n
                self.cnt += total // p
                self.psc_count = total % p
                return
            n -= to_event
            self.cnt = self.psc_count = 0
            if above:
                continue
            self._update_event(1)
            period = (self.psc_active + 1) * (self.arr_active + 1)  # periodic from here on
            if self.arr_active and n >= period:
                self._update_event(n // period)
                n %= period

    def _update_event(self, k: int) -> None:
        """``k`` overflow update events (none take effect while UDIS)."""
        if self.cr1 & UDIS:
            return
        self.updates += k
        self.psc_active = self.psc
        self.arr_active = self.arr
        self._raise_uif()
        if (self.cr2 >> 4 & 7) == MMS_UPDATE:
            self.trgo_count += k

    def _raise_uif(self) -> None:
        self.sr |= UIF
        if self.dier & UIE:
            self.machine.nvic.set_pending(self.irq)

    def next_event_s(self) -> float | None:
        """Emulated time (s) of the next update event, None when the counter is stopped."""
        if not self.cr1 & CEN:
            return None
        need = self._to_update()
        if need is None:
            return None
        if not self._slave():
            return (self._tick + need) / self._clock_hz()
        master = self._master()
        need -= master.trgo_count - self._master_seen
        return master._now_s if need <= 0 else master.trgo_time_s(need)

    def trgo_time_s(self, n: int) -> float | None:
        """Emulated time (s) of the ``n``-th TRGO pulse from now (n ≥ 1), None if none comes."""
        if (not self.cr1 & CEN or self.cr1 & UDIS or self._slave()
                or (self.cr2 >> 4 & 7) != MMS_UPDATE):
            return None
        first = self._to_update()
        if first is None or self.arr == 0:
            return None
        period = (self.psc + 1) * (self.arr + 1)
        return (self._tick + first + (n - 1) * period) / self._clock_hz()

    # -- registers ---------------------------------------------------------------------------

    def read_register(self, offset: int) -> int:
        """CR1, CR2, SMCR, DIER, SR, CNT, PSC, ARR (preload values); EGR reads 0."""
        regs = {CR1: self.cr1, CR2: self.cr2, SMCR: self.smcr, DIER: self.dier, SR: self.sr,
                EGR: 0, CNT: self.cnt, PSC: self.psc, ARR: self.arr}
        if offset in regs:
            return regs[offset]
        self._no_register(offset)

    def write_register(self, offset: int, value: int) -> None:
        """Writes one register (16 bits), failing on modes that are not modelled."""
        if offset == SR:
            # SR is rc_w0: writing 1 leaves a flag as it is, so ``SR = ~UIF`` (ones everywhere but the flag
            # to clear, the usual idiom, with 1s in the reserved bits 31:16 too) clears UIF alone
            value &= 0xFFFF
        if value >> 16:
            self.misuse(f"reserved bits 31:16 written at offset 0x{offset:02X}: 0x{value:08X}")
        handler = {CR1: self._write_cr1, CR2: self._write_cr2, SMCR: self._write_smcr,
                   DIER: self._write_dier, SR: self._write_sr, EGR: self._write_egr}.get(offset)
        if handler is not None:
            handler(value)
        elif offset == CNT:
            self.cnt = value
        elif offset == PSC:
            self.psc = value
        elif offset == ARR:
            self.arr = value
            if not self.cr1 & ARPE:
                self.arr_active = value
        else:
            self._no_register(offset)

    def _no_register(self, offset: int) -> None:
        what = (f"{self.name}.{_UNMODELLED[offset]} not modelled" if offset in _UNMODELLED
                else "reserved offset")
        self.unmodelled(offset, what)

    def _write_cr1(self, value: int) -> None:
        for bit, what in ((OPM, "CR1.OPM (one-pulse mode)"), (DIR, "CR1.DIR (down-counting)"),
                          (3 << 5, "CR1.CMS (centre-aligned mode)"),
                          (3 << 8, "CR1.CKD (clock division)")):
            if value & bit:
                self.unmodelled(CR1, f"{what} not modelled: up-counting only")
        if value & 0xFC00:
            self.misuse(f"CR1 reserved bits written: 0x{value & 0xFC00:04X}")
        self.cr1 = value

    def _write_cr2(self, value: int) -> None:
        mms = value >> 4 & 7
        if value & ~(7 << 4) or mms not in (MMS_RESET, MMS_UPDATE):
            self.unmodelled(CR2, f"CR2 = 0x{value:04X} not modelled (only MMS = 000 reset or "
                                 f"010 update)")
        self.cr2 = value

    def _write_smcr(self, value: int) -> None:
        sms, ts = value & 7, value >> 4 & 7
        if value & ~0x77 or sms not in (0, SMS_EXTERNAL_1):
            self.unmodelled(SMCR, f"SMCR = 0x{value:04X} not modelled (only SMS = 000 internal "
                                  f"clock or 111 external clock mode 1 from ITRx)")
        if sms == SMS_EXTERNAL_1:
            if ts not in self.itr:
                self.unmodelled(SMCR, f"SMCR.TS = {ts:03b} not modelled for {self.name} "
                                      f"(modelled: " + ", ".join(
                                          f"{t:03b} = ITR{t} = {m}" for t, m in self.itr.items())
                                + ")")
            self.smcr = value
            master = self._master()
            master.advance(self._now_s)
            self._master_seen = master.trgo_count
        self.smcr = value

    def _write_dier(self, value: int) -> None:
        if value & ~UIE:
            self.unmodelled(DIER, f"DIER = 0x{value:04X} not modelled (only UIE)")
        self.dier = value
        if self.dier & UIE and self.sr & UIF:
            self.machine.nvic.set_pending(self.irq)

    def _write_sr(self, value: int) -> None:
        self.sr &= value | ~(UIF | TIF)  # rc_w0: a 0 clears, a 1 leaves the flag

    def _write_egr(self, value: int) -> None:
        if value & ~UG:
            self.unmodelled(EGR, f"EGR = 0x{value:04X} not modelled (only UG)")
        if not value & UG:
            return
        self.cnt = self.psc_count = 0  # RM0008 §15.4.6: counter and prescaler counter cleared
        mms = self.cr2 >> 4 & 7
        if mms == MMS_RESET:
            self.trgo_count += 1
        if self.cr1 & UDIS:
            return
        self.updates += 1
        self.psc_active = self.psc
        self.arr_active = self.arr
        if mms == MMS_UPDATE:
            self.trgo_count += 1
        if not self.cr1 & URS:
            self._raise_uif()


class Tim2(Timer):
    """TIM2 at 0x40000000, IRQ 28 (clock RCC.APB1ENR.TIM2EN)."""

    name = clock = "TIM2"
    base = 0x40000000
    irq = 28
    itr = {2: "TIM3", 3: "TIM4"}


class Tim3(Timer):
    """TIM3 at 0x40000400, IRQ 29 (clock RCC.APB1ENR.TIM3EN)."""

    name = clock = "TIM3"
    base = 0x40000400
    irq = 29
    itr = {1: "TIM2", 3: "TIM4"}


class Tim4(Timer):
    """TIM4 at 0x40000800, IRQ 30 (clock RCC.APB1ENR.TIM4EN)."""

    name = clock = "TIM4"
    base = 0x40000800
    irq = 30
    itr = {1: "TIM2", 2: "TIM3"}
