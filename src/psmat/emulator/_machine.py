"""The emulated STM32F103C8: unicorn's Cortex-M3, its memory map, the models and the run loop.

Unicorn facts this module relies on (unicorn 2.1.4, ``Uc(UC_ARCH_ARM, UC_MODE_THUMB |
UC_MODE_MCLASS)`` with ``ctl_set_cpu_model(UC_CPU_ARM_CORTEX_M3)``, which 2.1.4 accepts before
any memory is mapped), found with small programs:

* ``emu_start(begin | 1, until, count=N)`` runs N instructions, except that an IT instruction and
  the instructions of its block count as one: a slice never ends inside an IT block (the
  machine still checks the EPSR IT bits, ``UC_ARM_REG_XPSR`` bits 26:25 and 15:10, before it
  enters an exception; they read non-zero when emulation stops mid-block, e.g. at an ``until``
  address). ``UC_ARM_REG_XPSR``, ``EPSR``, ``IPSR``, ``PRIMASK``, ``BASEPRI``, ``FAULTMASK``,
  ``CONTROL`` and ``MSP`` read and write; writing XPSR sets IPSR, and with it handler mode.
* WFI stops ``emu_start`` after the instruction (the PC reads the next one); no hook is raised and
  no error returned. A UC_HOOK_CODE hook on the WFI's address tells it apart from the end of the
  count. CPSID/CPSIE and MSR BASEPRI just set PRIMASK/BASEPRI: unicorn has no NVIC.
* A branch to an EXC_RETURN value in handler mode raises UC_HOOK_INTR with number 8 (see
  :mod:`psmat.emulator._nvic`); writing the PC in that hook continues there.
* The PC read in MMIO callbacks and in UC_HOOK_MEM_UNMAPPED hooks is that of the accessing
  instruction (with a count, unicorn syncs it per instruction). For an unmapped *fetch* the PC is
  the fetched address; the message then adds LR, which names the caller for a ``blx``.
* An exception escaping a Python MMIO read callback makes ctypes print "Exception ignored": the
  callbacks here catch everything, keep the first error, call ``emu_stop`` and return 0.
* ``mmio_map`` and ``mem_map`` need 1 KiB-aligned ranges (``ctl_get_page_size()`` is 1024): the
  machine maps every page a model touches and dispatches by address within the page.
* ``emu_start`` with ``count`` costs about 2.5 µs per call plus about 7 ns per instruction here.

Time. ``now_s`` advances by ``cycles_per_instruction / SYSCLK`` per instruction executed (SYSCLK
from the RCC model, 8 MHz HSI without one) and jumps at WFI. The loop runs slices of at most
``max_slice_s`` (1 µs by default) and never past the earliest ``next_event_s()`` of the models
by more than one instruction (the budget is that event's distance in instructions, rounded up);
between slices it advances the models whose event is due, enters a pending interrupt that
preempts, and checks the run's limits. While an enabled interrupt pends that only PRIMASK or
BASEPRI holds off, slices are one instruction long, so it is taken right after the CPSIE or MSR
that unmasks it (the firmware's ``cpsid i; wfi; cpsie i`` would otherwise meet every slice
boundary with PRIMASK set). So a model's event is seen within one instruction, an unmasked
interrupt is taken at once, and what happens inside a slice (a register read of a
time-varying value, an interrupt pended by a register write) is timed to within
``max_slice_s``. A slice ended by WFI counts
its whole budget (unicorn does not say how many instructions ran before it stopped): at most
``max_slice_s`` of emulated time early, then the skip to the next event makes the time exact.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import NoReturn

from ._elf import Image, load_image
from ._errors import EmulationError, UnmodelledAccess
from ._nvic import Nvic
from ._peripheral import Peripheral

__all__ = ["FLASH_BASE", "FLASH_SIZE", "Machine", "SRAM_BASE", "SRAM_SIZE"]

FLASH_BASE, FLASH_SIZE = 0x08000000, 64 * 1024
SRAM_BASE, SRAM_SIZE = 0x20000000, 20 * 1024
PAGE = 0x400
HSI_HZ = 8e6
WFI = 0xBF30
EXCP_EXCEPTION_EXIT = 8
DEFAULT_UID = (0x12345678, 0x9ABCDEF0, 0x0F1E2D3C)
# Two emulated times closer than this are the same instant (s), as in the models.
TIME_TOLERANCE_S = 1e-12
_UNICORN_EXCEPTIONS = {1: "undefined instruction", 2: "SVC (not modelled)", 3: "prefetch abort",
                       4: "data abort", 7: "BKPT", 18: "invalid state (INVSTATE)"}


class _Page:
    """One 1 KiB page of MMIO and the models that overlap it."""

    __slots__ = ("base", "models")

    def __init__(self, base: int) -> None:
        self.base = base
        self.models: list[Peripheral] = []


class Machine:
    """An STM32F103C8 running an ELF image, with register-level models of its peripherals.

    Parameters
    ----------
    elf_path : str or Path
        The image (``make -C firmware stm32 LINK=uart`` → ``BUILD/stm32-uart/psm.elf``).
    cycles_per_instruction : float
        Clock cycles per instruction (a stated assumption; 1.0 by default).
    hse_hz : float
        The external crystal (Hz), for the RCC model.
    uid : tuple of 3 int
        The 96-bit unique device ID, as three 32-bit words.
    peripherals : iterable of Peripheral subclasses, optional
        The models to build (``cls(machine)``) and register, in order; by default every model of
        :data:`psmat.emulator.PERIPHERAL_CLASSES`. The NVIC/SCB is always there.
    max_slice_s : float
        The longest slice of instructions between two visits of the models (s of emulated time).

    Attributes
    ----------
    now_s : float
        Emulated time since reset (s).
    instructions : int
        Instructions executed (an IT block counts as one; see the module notes).
    image : Image
        The ELF's segments and symbols.
    nvic : Nvic
        The interrupt controller.
    """

    def __init__(self, elf_path: str | Path, *, cycles_per_instruction: float = 1.0,
                 hse_hz: float = 8e6, uid: tuple[int, int, int] = DEFAULT_UID,
                 peripherals: Iterable[type[Peripheral]] | None = None,
                 max_slice_s: float = 1e-6) -> None:
        from unicorn import UC_ARCH_ARM, UC_HOOK_INTR, UC_HOOK_MEM_INVALID, UC_MODE_MCLASS, UC_MODE_THUMB, Uc
        from unicorn.arm_const import UC_CPU_ARM_CORTEX_M3

        if not cycles_per_instruction > 0:
            raise ValueError(f"cycles_per_instruction must be > 0, got {cycles_per_instruction}")
        if not max_slice_s > 0:
            raise ValueError(f"max_slice_s must be > 0 s, got {max_slice_s}")
        self.image: Image = load_image(elf_path)
        self.cycles_per_instruction = float(cycles_per_instruction)
        self.hse_hz = float(hse_hz)
        self.uid = tuple(uid)
        self.max_slice_s = float(max_slice_s)
        self.now_s = 0.0
        self.instructions = 0
        self._peripherals: dict[str, Peripheral] = {}
        self._timed: list[Peripheral] = []
        self._pages: dict[int, _Page] = {}
        self._error: BaseException | None = None
        self._wfi_at: int | None = None
        self._sleeping = False

        uc = self._uc = Uc(UC_ARCH_ARM, UC_MODE_THUMB | UC_MODE_MCLASS)
        uc.ctl_set_cpu_model(UC_CPU_ARM_CORTEX_M3)
        self._load_flash()
        from unicorn import UC_PROT_ALL

        uc.mem_map(SRAM_BASE, SRAM_SIZE, UC_PROT_ALL)
        uc.hook_add(UC_HOOK_MEM_INVALID, self._guard(self._on_invalid, False))
        uc.hook_add(UC_HOOK_INTR, self._guard(self._on_interrupt, None))
        self._hook_wfis()

        self.nvic = Nvic(self)
        self.register(self.nvic)
        if peripherals is None:
            from ._stm32f103 import PERIPHERAL_CLASSES
            peripherals = PERIPHERAL_CLASSES
        for cls in peripherals:
            self.register(cls(self))
        self._reset_cpu()

    # -- set-up ------------------------------------------------------------------------------------

    def _load_flash(self) -> None:
        from unicorn import UC_PROT_EXEC, UC_PROT_READ

        self._flash = ctypes.create_string_buffer(b"\xff" * FLASH_SIZE, FLASH_SIZE)  # erased
        for address, data in self.image.segments:
            if not (FLASH_BASE <= address and address + len(data) <= FLASH_BASE + FLASH_SIZE):
                raise EmulationError(f"{self.image.path}: segment of {len(data)} bytes at load "
                                     f"address 0x{address:08X} outside the 64 KiB flash at "
                                     f"0x{FLASH_BASE:08X}")
            ctypes.memmove(ctypes.addressof(self._flash) + address - FLASH_BASE, data, len(data))
        for base in (0x00000000, FLASH_BASE):  # boot alias (BOOT0 = 0) and the flash itself
            self._uc.mem_map_ptr(base, FLASH_SIZE, UC_PROT_READ | UC_PROT_EXEC,
                                 ctypes.addressof(self._flash))

    def _hook_wfis(self) -> None:
        """A code hook on every halfword of the image that encodes WFI (0xBF30)."""
        from unicorn import UC_HOOK_CODE

        for address, data in self.image.segments:
            for i in range(0, len(data) - 1, 2):
                if data[i] | data[i + 1] << 8 == WFI:
                    at = address + i
                    self._uc.hook_add(UC_HOOK_CODE, self._guard(self._on_wfi, None), begin=at, end=at)

    def _reset_cpu(self) -> None:
        from unicorn.arm_const import UC_ARM_REG_MSP, UC_ARM_REG_PC, UC_ARM_REG_XPSR

        sp, reset = self.read_u32(0), self.read_u32(4)
        if not reset & 1:
            raise EmulationError(f"{self.image.path}: reset vector 0x{reset:08X} lacks the Thumb bit")
        self._uc.reg_write(UC_ARM_REG_MSP, sp)
        self._uc.reg_write(UC_ARM_REG_XPSR, 1 << 24)
        self._uc.reg_write(UC_ARM_REG_PC, reset)

    def register(self, peripheral: Peripheral) -> None:
        """Adds a model: its ``size`` bytes at ``base`` are served by its read/write.

        Raises
        ------
        ValueError
            When its name is taken, its range overlaps another model's, or it lies on memory.
        """
        from unicorn import UcError

        name, base, end = peripheral.name, peripheral.base, peripheral.base + peripheral.size
        if not name or name in self._peripherals:
            raise ValueError(f"peripheral name {name!r} is empty or already registered")
        if peripheral.size <= 0:
            raise ValueError(f"{name}: size must be > 0, got {peripheral.size}")
        for other in self._peripherals.values():
            if base < other.base + other.size and other.base < end:
                raise ValueError(f"{name} at 0x{base:08X}-0x{end - 1:08X} overlaps {other.name}")
        first = base - base % PAGE
        for page in range(first, end, PAGE):
            if page not in self._pages:
                slot = _Page(page)
                try:
                    self._uc.mmio_map(page, PAGE, self._guard(self._mmio_read, 0), slot,
                                      self._guard(self._mmio_write, None), slot)
                except UcError as exc:
                    raise ValueError(f"{name} at 0x{base:08X}: page 0x{page:08X} cannot be "
                                     f"mapped ({exc}); it overlaps memory") from None
                self._pages[page] = slot
        for page in range(first, end, PAGE):
            self._pages[page].models.append(peripheral)
        self._peripherals[name] = peripheral
        if type(peripheral).next_event_s is not Peripheral.next_event_s:
            self._timed.append(peripheral)

    # -- what the models and the harness use ------------------------------------------------------

    def peripheral(self, name: str) -> Peripheral:
        """The model called ``name`` (e.g. ``"TIM3"``)."""
        try:
            return self._peripherals[name]
        except KeyError:
            raise KeyError(f"no peripheral model {name!r}; have {', '.join(self._peripherals)}") from None

    @property
    def peripherals(self) -> tuple[Peripheral, ...]:
        """Every registered model, the NVIC first."""
        return tuple(self._peripherals.values())

    @property
    def rcc(self):  # noqa: ANN201 - the RCC model's class lives with the models
        """The RCC model, or None when the machine has none."""
        return self._peripherals.get("RCC")

    @property
    def sysclk_hz(self) -> float:
        """The CPU clock (Hz): the RCC model's SYSCLK, or the 8 MHz HSI without one."""
        rcc = self.rcc
        return float(rcc.clock_hz("SYSCLK")) if rcc is not None else HSI_HZ

    @property
    def pc(self) -> int:
        """The address of the instruction being (or next) executed."""
        from unicorn.arm_const import UC_ARM_REG_PC

        return self._uc.reg_read(UC_ARM_REG_PC)

    def reg(self, name: str) -> int:
        """A CPU register by unicorn's name without prefix (``"R0"``, ``"SP"``, ``"XPSR"``)."""
        from unicorn import arm_const

        return self._uc.reg_read(getattr(arm_const, f"UC_ARM_REG_{name.upper()}"))

    def on_instruction(self, callback: Callable[[int], None], begin: int, end: int) -> None:
        """Call ``callback(address)`` before every instruction executed at ``begin <= address <= end``.

        For measurements (``python -m psmat.bench firmware`` counts instructions per function); a
        hook on a wide range slows the emulation down, so keep ranges to what is measured.
        """
        from unicorn import UC_HOOK_CODE

        self._uc.hook_add(UC_HOOK_CODE, lambda _uc, address, _size, _data: callback(address), begin=begin, end=end)

    @property
    def symbols(self) -> dict[str, int]:
        """Symbol name → address (Thumb bit cleared) from the ELF."""
        return self.image.symbols

    @property
    def sleeping(self) -> bool:
        """Whether the CPU is in WFI."""
        return self._sleeping

    def where(self, address: int) -> str:
        """``"name+0xOFF"`` of the function holding ``address``, or ``""``."""
        found = self.image.function_at(address)
        return f"{found[0]}+0x{found[1]:X}" if found else ""

    def fail(self, cls: type[EmulationError], text: str) -> NoReturn:
        """Raises ``cls(text + " at PC 0x........ (function+0xOFF)")``; never returns."""
        pc = self.pc
        where = self.where(pc)
        error = cls(f"{text} at PC 0x{pc:08X}" + (f" ({where})" if where else ""))
        if self._error is None:
            self._error = error
        raise error

    def memory(self, address: int, n: int) -> bytes:
        """``n`` bytes of flash (or its alias at 0) or SRAM, without side effects.

        Raises
        ------
        ValueError
            When the range is not wholly in flash, its alias or SRAM.
        """
        for base, size in ((0, FLASH_SIZE), (FLASH_BASE, FLASH_SIZE), (SRAM_BASE, SRAM_SIZE)):
            if base <= address and address + n <= base + size and n >= 0:
                return bytes(self._uc.mem_read(address, n))
        raise ValueError(f"memory: 0x{address:08X}+{n} is not in flash or SRAM")

    def read_u32(self, address: int) -> int:
        """The little-endian word at ``address`` (flash or SRAM)."""
        return int.from_bytes(self.memory(address, 4), "little")

    def _write_stack(self, address: int, data: bytes, what: str) -> None:
        if not (SRAM_BASE <= address and address + len(data) <= SRAM_BASE + SRAM_SIZE):
            self.fail(UnmodelledAccess, f"{what}: stacking {len(data)} bytes at 0x{address:08X} "
                                        f"(outside SRAM)")
        self._uc.mem_write(address, data)

    def _read_stack(self, address: int, n: int, what: str) -> bytes:
        if not (SRAM_BASE <= address and address + n <= SRAM_BASE + SRAM_SIZE):
            self.fail(UnmodelledAccess, f"{what}: unstacking {n} bytes at 0x{address:08X} (outside SRAM)")
        return bytes(self._uc.mem_read(address, n))

    # -- unicorn callbacks --------------------------------------------------------------------------

    def _guard(self, func: Callable, default: object) -> Callable:
        """Wraps a callback: an exception is kept (the first wins), emulation stops."""

        def callback(uc, *args):  # noqa: ANN001, ANN202 - unicorn's signature
            try:
                return func(*args)
            except BaseException as exc:  # noqa: BLE001 - re-raised after emu_start
                if self._error is None:
                    self._error = exc
                uc.emu_stop()
                return default

        return callback

    def _mmio_read(self, offset: int, size: int, slot: _Page) -> int:
        address = slot.base + offset
        for model in slot.models:
            if model.base <= address < model.base + model.size:
                return model.read(address - model.base, size) & ((1 << (8 * size)) - 1)
        self.fail(UnmodelledAccess, f"read of {size} bytes at 0x{address:08X} (no model)")

    def _mmio_write(self, offset: int, size: int, value: int, slot: _Page) -> None:
        address = slot.base + offset
        for model in slot.models:
            if model.base <= address < model.base + model.size:
                model.write(address - model.base, size, value & ((1 << (8 * size)) - 1))
                return
        self.fail(UnmodelledAccess, f"write of {size} bytes at 0x{address:08X} (no model)")

    def _on_invalid(self, access: int, address: int, size: int, value: int, _data: object) -> bool:
        from unicorn import (UC_MEM_FETCH_PROT, UC_MEM_FETCH_UNMAPPED, UC_MEM_READ_UNMAPPED,
                             UC_MEM_WRITE_PROT, UC_MEM_WRITE_UNMAPPED)

        if access in (UC_MEM_FETCH_UNMAPPED, UC_MEM_FETCH_PROT):
            what = "no memory" if access == UC_MEM_FETCH_UNMAPPED else "not executable"
            lr = self.reg("LR")
            caller = self.where((lr & ~1) - 2)
            self.fail(UnmodelledAccess, f"instruction fetch at 0x{address:08X} ({what}; LR "
                                        f"0x{lr:08X}" + (f", {caller}" if caller else "") + ")")
        if access == UC_MEM_WRITE_PROT:
            self.fail(UnmodelledAccess, f"write of {size} bytes at 0x{address:08X} (flash is read-only)")
        kind = {UC_MEM_READ_UNMAPPED: "read", UC_MEM_WRITE_UNMAPPED: "write"}.get(access, "access")
        self.fail(UnmodelledAccess, f"{kind} of {size} bytes at 0x{address:08X} (no model)")

    def _on_interrupt(self, intno: int, _data: object) -> None:
        if intno == EXCP_EXCEPTION_EXIT:
            self.nvic.exception_return(self.pc | 1)
            return
        what = _UNICORN_EXCEPTIONS.get(intno, "CPU exception")
        self.fail(EmulationError, f"{what} (unicorn interrupt {intno})")

    def _on_wfi(self, address: int, size: int, _data: object) -> None:
        self._wfi_at = address

    # -- the run loop -----------------------------------------------------------------------------

    def run(self, until_s: float | None = None, *, instructions: int | None = None,
            until: Callable[[], bool] | None = None) -> None:
        """Runs the image until a limit is reached.

        Parameters
        ----------
        until_s : float, optional
            Stop once the emulated time reaches this (s).
        instructions : int, optional
            Stop after about this many more instructions (a slice ended by WFI counts whole).
        until : callable, optional
            Stop once ``until()`` is true (checked between slices).

        Raises
        ------
        EmulationError
            Whatever the image did that is not modelled (:class:`UnmodelledAccess`, ``Misuse``
            from a model, a CPU fault), or WFI with no event to come before the limit.
        """
        if until_s is None and instructions is None and until is None:
            raise ValueError("run needs until_s, instructions or until")
        stop_at = None if instructions is None else self.instructions + int(instructions)
        nvic = self.nvic
        while True:
            if until is not None and until():
                return
            if until_s is not None and self.now_s >= until_s - TIME_TOLERANCE_S:
                return
            if stop_at is not None and self.instructions >= stop_at:
                return
            next_s, source = self._service()
            step = False
            if nvic.pending & nvic.enabled:
                if self._sleeping and nvic.wants_wakeup():
                    self._sleeping = False
                if not self._sleeping:
                    nvic.take_pending()
                    step = nvic.held_off()
            if self._sleeping:
                target = next_s if until_s is None or (next_s is not None and next_s < until_s) else until_s
                if target is None:
                    self.fail(EmulationError, "WFI with no interrupt to come (no peripheral event "
                                              "pending, no time limit)")
                if target <= self.now_s + TIME_TOLERANCE_S and target is next_s:
                    self.fail(EmulationError, f"{source.name}: next_event_s() = {next_s!r} s is "
                                              f"still due after advance({self.now_s!r})")
                self.now_s = max(self.now_s, target)
                continue
            per_s = self.sysclk_hz / self.cycles_per_instruction     # instructions per second
            self._slice(1 if step else self._budget(per_s, next_s, until_s, stop_at), per_s)

    def _service(self) -> tuple[float | None, Peripheral | None]:
        """Advances the models whose event is due; the earliest event still to come (s) and
        its model."""
        now = self.now_s
        earliest, source = None, None
        for model in self._timed:
            t = model.next_event_s()
            if t is not None and t <= now + TIME_TOLERANCE_S:
                model.advance(now)
                t = model.next_event_s()
            if t is not None and (earliest is None or t < earliest):
                earliest, source = t, model
        return earliest, source

    def _budget(self, per_s: float, next_s: float | None, until_s: float | None,
                stop_at: int | None) -> int:
        """Instructions of the next slice: up to ``max_slice_s``, the next event (rounded up,
        so that it is due at the slice's end), ``until_s`` and the instruction limit."""
        budget = max(1, int(self.max_slice_s * per_s))
        for t in (next_s, until_s):
            if t is not None:
                budget = min(budget, max(1, math.ceil((t - self.now_s) * per_s - 1e-9)))
        if stop_at is not None:
            budget = min(budget, max(1, stop_at - self.instructions))
        return budget

    def _slice(self, budget: int, per_s: float) -> None:
        """Runs ``budget`` instructions (fewer when WFI stops it) at ``per_s`` per second."""
        from unicorn import UcError

        self._error = None
        self._wfi_at = None
        try:
            self._uc.emu_start(self.pc | 1, 0xFFFFFFFF, 0, budget)
        except UcError as exc:
            if self._error is None:
                self._error = EmulationError(f"unicorn stopped: {exc} at PC 0x{self.pc:08X}")
        if self._error is not None:
            error, self._error = self._error, None
            raise error
        if self._wfi_at is not None:
            self._sleeping = True
        self.instructions += budget
        self.now_s += budget / per_s
