"""NVIC and SCB of the Cortex-M3 in the STM32F103, and exception entry and return.

Unicorn has no interrupt controller: this model keeps the enabled, pending and active state and
the priorities of IRQ 0-42 (the medium-density vector table, RM0008 table 63), and the machine
asks it between instruction slices whether to take an interrupt (:meth:`Nvic.take_pending`).
Entry and return are carried out here on the unicorn CPU as the ARMv7-M architecture does them:

* entry: 8 words stacked on the main stack, at ``SP - 32`` (R0-R3, R12, LR, the return address,
  xPSR); with CCR.STKALIGN (set at reset, PM0056 §4.4.7) a stack pointer that is not 8-byte
  aligned is first lowered by 4 and bit 9 of the stacked xPSR set; LR = EXC_RETURN 0xFFFFFFF9
  (from thread mode) or 0xFFFFFFF1 (from a handler); IPSR = 16 + IRQ; PC = the vector read at
  VTOR + 4·(16 + IRQ). Entry costs no emulated time (the 12 cycles of the hardware are not
  counted).
* return: unicorn 2.1.4 (Cortex-M3 model) turns a branch to an EXC_RETURN value in handler mode
  (``bx lr``, ``pop {..., pc}``) into a UC_HOOK_INTR callback with interrupt number 8 (QEMU's
  EXCP_EXCEPTION_EXIT), the PC reading the EXC_RETURN value with bit 0 clear (0xFFFFFFF8 for
  0xFFFFFFF9); left alone, it then raises number 3 (prefetch abort) at that address for ever.
  The machine's hook calls :meth:`Nvic.exception_return`, which tail-chains to the best pending
  IRQ that may preempt the context being returned to (the frame stays stacked, LR unchanged), or
  unstacks the frame (restoring IPSR and the EPSR bits from the stacked xPSR) and writes the PC;
  unicorn then continues at the new PC within the same ``emu_start``.

Priorities: the STM32F103 implements the top 4 bits of each 8-bit priority (so of BASEPRI too).
An IRQ preempts when its group priority (AIRCR.PRIGROUP) is below the execution priority: that of
the active exceptions, lowered to BASEPRI when non-zero, to 0 by PRIMASK and to -1 by
FAULTMASK; thread mode alone is 256. Among pending IRQs the lowest priority value wins, then the
lowest number. WFI wakes on an IRQ that would preempt if PRIMASK were clear (ARMv7-M B1.5.19).

Registers modelled (PM0056 §4.3, §4.4): ICTR; ISER, ICER, ISPR, ICPR, IABR (words 0 and 1);
IPR (bytes, half-words or words); STIR; CPUID, ICSR (read), VTOR, AIRCR (PRIGROUP; a reset
request fails the run), SCR (0 only), CCR, SHPR1-3, SHCSR. Any other SCS address (SysTick, MPU,
the fault status registers, debug) fails with :class:`UnmodelledAccess`.
"""

from __future__ import annotations

import struct
from ._errors import EmulationError, Misuse, UnmodelledAccess
from ._peripheral import Peripheral

__all__ = ["EXC_RETURN_HANDLER", "EXC_RETURN_THREAD", "N_IRQ", "Nvic"]

N_IRQ = 43                     # IRQ 0-42 on the STM32F103 medium density (RM0008 table 63)
PRIORITY_MASK = 0xF0           # 4 priority bits implemented (RM0008 §10.1.1)
EXC_RETURN_HANDLER = 0xFFFFFFF1
EXC_RETURN_THREAD = 0xFFFFFFF9
EXC_RETURN_THREAD_PSP = 0xFFFFFFFD
THREAD_PRIORITY = 256
IT_BITS = 0x0600FC00           # EPSR IT[1:0] (bits 26:25) and IT[7:2] (bits 15:10)
STACK_ALIGN_BIT = 1 << 9       # stacked xPSR: SP was lowered by 4 for 8-byte alignment
CPUID = 0x411FC231             # Cortex-M3 r1p1 (PM0056 §4.4.1)
STKALIGN = 1 << 9              # CCR: 8-byte stack alignment on exception entry
CCR_RESET = STKALIGN           # PM0056 §4.4.7
AIRCR_VECTKEY = 0x05FA

# register offsets from 0xE000E000
ICTR, STIR = 0x004, 0xF00
ISER, ICER, ISPR, ICPR, IABR = 0x100, 0x180, 0x200, 0x280, 0x300
IPR, IPR_END = 0x400, 0x400 + 4 * ((N_IRQ + 3) // 4)
CPUID_REG, ICSR, VTOR, AIRCR, SCR, CCR = 0xD00, 0xD04, 0xD08, 0xD0C, 0xD10, 0xD14
SHPR, SHPR_END, SHCSR = 0xD18, 0xD24, 0xD24
_BIT_REGISTERS = {ISER: "ISER", ICER: "ICER", ISPR: "ISPR", ICPR: "ICPR", IABR: "IABR"}


class Nvic(Peripheral):
    """The nested vectored interrupt controller and system control block (0xE000E000-0xE000EFFF).

    Attributes
    ----------
    enabled, pending, active : int
        Bit masks over IRQ numbers.
    priority : bytearray
        The priority byte of each IRQ (low 4 bits read as 0).
    vtor : int
        The vector table offset (0 at reset: the flash alias at 0x00000000).
    """

    name = "NVIC"
    base = 0xE000E000
    size = 0x1000

    def reset(self) -> None:
        """All IRQs disabled, not pending, priority 0; VTOR 0, PRIGROUP 0, CCR.STKALIGN set."""
        self.enabled = 0
        self.pending = 0
        self.active = 0
        self.priority = bytearray(N_IRQ)
        self.vtor = 0
        self.prigroup = 0
        self.ccr = CCR_RESET
        self.shpr = bytearray(SHPR_END - SHPR)
        self.shcsr = 0
        self._stack: list[int] = []   # active IRQs, outermost first

    # -- the state, for the peripheral models and the machine ----------------------------------

    @staticmethod
    def _check(irq: int) -> int:
        if not 0 <= irq < N_IRQ:
            raise ValueError(f"NVIC: IRQ {irq} out of range 0..{N_IRQ - 1}")
        return irq

    def set_pending(self, irq: int) -> None:
        """Pends IRQ ``irq`` (0-42); it is taken between slices when enabled and preempting."""
        self.pending |= 1 << self._check(irq)

    def clear_pending(self, irq: int) -> None:
        """Clears the pending bit of IRQ ``irq`` (0-42)."""
        self.pending &= ~(1 << self._check(irq))

    def is_pending(self, irq: int) -> bool:
        """Whether IRQ ``irq`` is pending."""
        return bool(self.pending >> self._check(irq) & 1)

    def is_enabled(self, irq: int) -> bool:
        """Whether IRQ ``irq`` is enabled (ISER)."""
        return bool(self.enabled >> self._check(irq) & 1)

    @property
    def active_irqs(self) -> tuple[int, ...]:
        """The active IRQs, outermost (first preempted) first."""
        return tuple(self._stack)

    def group_priority(self, priority: int) -> int:
        """The preempting part of a priority byte under AIRCR.PRIGROUP."""
        return priority & PRIORITY_MASK & (0xFF << (self.prigroup + 1))

    def execution_priority(self, *, primask: bool = True, basepri: bool = True) -> int:
        """The current execution priority (256 in thread mode with nothing masked).

        Parameters
        ----------
        primask : bool
            Count PRIMASK (False for WFI's wake-up rule).
        basepri : bool
            Count BASEPRI (and FAULTMASK).
        """
        from unicorn.arm_const import UC_ARM_REG_BASEPRI, UC_ARM_REG_FAULTMASK, UC_ARM_REG_PRIMASK

        uc = self.machine._uc
        level = THREAD_PRIORITY
        for irq in self._stack:
            level = min(level, self.group_priority(self.priority[irq]))
        if basepri:
            mask = uc.reg_read(UC_ARM_REG_BASEPRI) & PRIORITY_MASK
            if mask:
                level = min(level, self.group_priority(mask))
            if uc.reg_read(UC_ARM_REG_FAULTMASK) & 1:
                level = -1
        if primask and uc.reg_read(UC_ARM_REG_PRIMASK) & 1:
            level = min(level, 0)
        return level

    def best_pending(self, level: int) -> int | None:
        """The pending, enabled IRQ that would preempt execution priority ``level``, or None."""
        candidates = self.pending & self.enabled
        best: tuple[int, int] | None = None
        while candidates:
            irq = (candidates & -candidates).bit_length() - 1
            candidates &= candidates - 1
            key = (self.priority[irq], irq)
            if best is None or key < best:
                best = key
        if best is None or self.group_priority(best[0]) >= level:
            return None
        return best[1]

    def held_off(self) -> bool:
        """Whether an enabled IRQ pends that only PRIMASK, BASEPRI (or an IT block) holds off.

        The machine then runs one instruction per slice, so that the IRQ is taken right after
        the instruction that lifts the mask (CPSIE, MSR BASEPRI) and not a slice later.
        """
        return bool(self.pending & self.enabled) and \
            self.best_pending(self.execution_priority(primask=False, basepri=False)) is not None

    def wants_wakeup(self) -> bool:
        """Whether WFI ends now: an enabled IRQ pends that would preempt but for PRIMASK."""
        return bool(self.pending & self.enabled) and \
            self.best_pending(self.execution_priority(primask=False)) is not None

    # -- exception entry and return ---------------------------------------------------------------

    def take_pending(self) -> bool:
        """Enters the best pending IRQ if it preempts the current execution (between slices).

        Not inside an IT block (EPSR IT bits non-zero). Repeats while a still better IRQ pends
        (the hardware's late arrival: the later, higher-priority handler runs first).

        Returns
        -------
        bool
            Whether an exception was entered.
        """
        from unicorn.arm_const import UC_ARM_REG_XPSR

        taken = False
        while self.pending & self.enabled:
            irq = self.best_pending(self.execution_priority())
            if irq is None or self.machine._uc.reg_read(UC_ARM_REG_XPSR) & IT_BITS:
                break
            self._enter(irq)
            taken = True
        return taken

    def _vector(self, irq: int) -> int:
        address = self.vtor + 4 * (16 + irq)
        try:
            vector = self.machine.read_u32(address)
        except ValueError:
            self.machine.fail(EmulationError, f"vector of IRQ {irq} at 0x{address:08X} outside "
                                              f"flash and SRAM (VTOR 0x{self.vtor:08X})")
        if not vector & 1:
            self.machine.fail(EmulationError, f"vector of IRQ {irq} at 0x{address:08X} is "
                                              f"0x{vector:08X}, without the Thumb bit (INVSTATE)")
        return vector

    def _enter(self, irq: int) -> None:
        from unicorn.arm_const import (UC_ARM_REG_CONTROL, UC_ARM_REG_LR, UC_ARM_REG_PC, UC_ARM_REG_R0,
                                       UC_ARM_REG_R1, UC_ARM_REG_R2, UC_ARM_REG_R3, UC_ARM_REG_R12,
                                       UC_ARM_REG_SP, UC_ARM_REG_XPSR)

        uc = self.machine._uc
        xpsr = uc.reg_read(UC_ARM_REG_XPSR)
        if uc.reg_read(UC_ARM_REG_CONTROL) & 2:
            self.machine.fail(EmulationError, f"IRQ {irq} entry with the process stack in use "
                                              f"(CONTROL.SPSEL = 1, not modelled)")
        vector = self._vector(irq)
        sp = uc.reg_read(UC_ARM_REG_SP)
        stacked_xpsr = xpsr & ~STACK_ALIGN_BIT
        if self.ccr & STKALIGN and sp & 4:
            sp -= 4
            stacked_xpsr |= STACK_ALIGN_BIT
        sp -= 32
        frame = [uc.reg_read(r) for r in (UC_ARM_REG_R0, UC_ARM_REG_R1, UC_ARM_REG_R2, UC_ARM_REG_R3,
                                          UC_ARM_REG_R12, UC_ARM_REG_LR)]
        frame += [uc.reg_read(UC_ARM_REG_PC) & ~1, stacked_xpsr]
        self.machine._write_stack(sp, struct.pack("<8I", *frame), f"IRQ {irq} entry")
        uc.reg_write(UC_ARM_REG_SP, sp)
        uc.reg_write(UC_ARM_REG_LR, EXC_RETURN_HANDLER if xpsr & 0x1FF else EXC_RETURN_THREAD)
        uc.reg_write(UC_ARM_REG_XPSR, (xpsr & 0xF8000000) | (1 << 24) | (16 + irq))
        uc.reg_write(UC_ARM_REG_PC, vector)
        self.pending &= ~(1 << irq)
        self.active |= 1 << irq
        self._stack.append(irq)

    def exception_return(self, exc_return: int) -> None:
        """Returns from the innermost active IRQ (unicorn's interrupt 8), or tail-chains.

        Parameters
        ----------
        exc_return : int
            The EXC_RETURN value branched to (0xFFFFFFF1 or 0xFFFFFFF9; 0xFFFFFFFD, the process
            stack, is not modelled).
        """
        from unicorn.arm_const import (UC_ARM_REG_LR, UC_ARM_REG_PC, UC_ARM_REG_R0, UC_ARM_REG_R1,
                                       UC_ARM_REG_R2, UC_ARM_REG_R3, UC_ARM_REG_R12, UC_ARM_REG_SP,
                                       UC_ARM_REG_XPSR)

        uc = self.machine._uc
        ipsr = uc.reg_read(UC_ARM_REG_XPSR) & 0x1FF
        if not self._stack or ipsr != 16 + self._stack[-1]:
            self.machine.fail(EmulationError, f"exception return 0x{exc_return:08X} from IPSR {ipsr}, "
                              f"which is not the active IRQ (active: {list(self._stack)})")
        irq = self._stack.pop()
        self.active &= ~(1 << irq)
        if exc_return not in (EXC_RETURN_HANDLER, EXC_RETURN_THREAD):
            self.machine.fail(EmulationError, f"exception return 0x{exc_return:08X} from IRQ {irq} "
                                              f"(only the main stack is modelled)")
        if (exc_return == EXC_RETURN_THREAD) != (not self._stack):
            target = "thread mode" if exc_return == EXC_RETURN_THREAD else "a handler"
            self.machine.fail(EmulationError, f"exception return 0x{exc_return:08X} from IRQ {irq} "
                              f"to {target} with IRQs {list(self._stack)} still active (INVPC)")
        chained = self.best_pending(self.execution_priority()) if self.pending & self.enabled else None
        if chained is not None:       # tail-chain: the frame stays, LR keeps this EXC_RETURN
            uc.reg_write(UC_ARM_REG_XPSR, (uc.reg_read(UC_ARM_REG_XPSR) & ~0x1FF) | (16 + chained))
            uc.reg_write(UC_ARM_REG_PC, self._vector(chained))
            uc.reg_write(UC_ARM_REG_LR, exc_return)
            self.pending &= ~(1 << chained)
            self.active |= 1 << chained
            self._stack.append(chained)
            return
        sp = uc.reg_read(UC_ARM_REG_SP)
        r0, r1, r2, r3, r12, lr, pc, xpsr = struct.unpack("<8I", self.machine._read_stack(
            sp, 32, f"exception return from IRQ {irq}"))
        expected = 16 + self._stack[-1] if self._stack else 0
        if xpsr & 0x1FF != expected:
            self.machine.fail(EmulationError, f"exception return from IRQ {irq}: stacked IPSR "
                              f"{xpsr & 0x1FF} at 0x{sp:08X}, expected {expected} (corrupt frame)")
        for reg, value in ((UC_ARM_REG_R0, r0), (UC_ARM_REG_R1, r1), (UC_ARM_REG_R2, r2),
                           (UC_ARM_REG_R3, r3), (UC_ARM_REG_R12, r12), (UC_ARM_REG_LR, lr)):
            uc.reg_write(reg, value)
        uc.reg_write(UC_ARM_REG_SP, sp + 32 + (4 if xpsr & STACK_ALIGN_BIT else 0))
        uc.reg_write(UC_ARM_REG_XPSR, xpsr & ~STACK_ALIGN_BIT)
        uc.reg_write(UC_ARM_REG_PC, pc | 1)

    # -- the registers -------------------------------------------------------------------------------

    def _fail(self, cls: type[EmulationError], text: str) -> None:
        self.machine.fail(cls, f"NVIC/SCB: {text}")

    def read(self, offset: int, size: int) -> int:
        """Value of the ``size``-byte read at ``0xE000E000 + offset``."""
        if IPR <= offset < IPR_END or SHPR <= offset < SHPR_END:
            table, start = (self.priority, IPR) if offset < IPR_END else (self.shpr, SHPR)
            lanes = [table[i - start] if i - start < len(table) else 0
                     for i in range(offset, offset + size)]
            return int.from_bytes(bytes(lanes), "little")
        self._word_only("read", offset, size)
        base = offset & ~0x7F if 0x100 <= offset < 0x380 else None
        if base in _BIT_REGISTERS and offset - base < 8:
            mask = {ISER: self.enabled, ICER: self.enabled, ISPR: self.pending, ICPR: self.pending,
                    IABR: self.active}[base]
            return mask >> (8 * (offset - base)) & 0xFFFFFFFF
        if offset == ICTR:
            return 1                      # (1 + 1) x 32 interrupt lines
        if offset == CPUID_REG:
            return CPUID
        if offset == ICSR:
            return self._icsr()
        if offset == VTOR:
            return self.vtor
        if offset == AIRCR:
            return 0xFA050000 | self.prigroup << 8
        if offset == SCR:
            return 0
        if offset == CCR:
            return self.ccr
        if offset == SHCSR:
            return self.shcsr
        self.machine.fail(UnmodelledAccess, f"read of {size} bytes at 0x{self.base + offset:08X} "
                                            f"(no model in the NVIC/SCB)")
        return 0  # pragma: no cover - fail raises

    def _icsr(self) -> int:
        from unicorn.arm_const import UC_ARM_REG_XPSR

        value = self.machine._uc.reg_read(UC_ARM_REG_XPSR) & 0x1FF             # VECTACTIVE
        best = self.best_pending(THREAD_PRIORITY + 1)
        if best is not None:
            value |= (16 + best) << 12                                         # VECTPENDING
        if self.pending:
            value |= 1 << 22                                                   # ISRPENDING
        if len(self._stack) <= 1:
            value |= 1 << 11                                                   # RETTOBASE
        return value

    def _word_only(self, kind: str, offset: int, size: int) -> None:
        if size != 4 or offset % 4:
            self._fail(Misuse, f"{size}-byte {kind} at 0x{self.base + offset:08X}: word access "
                               f"only (PM0056 §4.3)")

    def write(self, offset: int, size: int, value: int) -> None:
        """Carries out the ``size``-byte write of ``value`` at ``0xE000E000 + offset``."""
        if IPR <= offset < IPR_END or SHPR <= offset < SHPR_END:
            table, start = (self.priority, IPR) if offset < IPR_END else (self.shpr, SHPR)
            for i, byte in enumerate(value.to_bytes(size, "little")):
                if offset + i - start < len(table):
                    table[offset + i - start] = byte & PRIORITY_MASK
            return
        self._word_only("write", offset, size)
        base = offset & ~0x7F if 0x100 <= offset < 0x380 else None
        if base in _BIT_REGISTERS and offset - base < 8 and base != IABR:
            bits = (value << (8 * (offset - base))) & ((1 << N_IRQ) - 1)
            if base == ISER:
                self.enabled |= bits
            elif base == ICER:
                self.enabled &= ~bits
            elif base == ISPR:
                self.pending |= bits
            else:
                self.pending &= ~bits
            return
        if offset == STIR:
            if (value & 0x1FF) < N_IRQ:
                self.set_pending(value & 0x1FF)
            return
        if offset == VTOR:
            self.vtor = value & 0x3FFFFF80
            return
        if offset == AIRCR:
            if value >> 16 != AIRCR_VECTKEY:
                return                                   # ignored without the key
            if value & 0b101:
                self._fail(EmulationError, f"reset requested through AIRCR (0x{value:08X}), not modelled")
            self.prigroup = value >> 8 & 7
            return
        if offset == SCR:
            if value & 0b10110:
                self._fail(UnmodelledAccess, f"SCR = 0x{value:08X}: SLEEPONEXIT, SLEEPDEEP and "
                                             f"SEVONPEND are not modelled")
            return
        if offset == CCR:
            self.ccr = value & 0x31B
            return
        if offset == SHCSR:
            self.shcsr = value & 0x70000
            return
        self.machine.fail(UnmodelledAccess, f"write of {size} bytes at 0x{self.base + offset:08X} "
                                            f"(no model in the NVIC/SCB)")
