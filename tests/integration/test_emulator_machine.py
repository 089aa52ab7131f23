"""The emulated Cortex-M3 (psmat.emulator.Machine, docs/spec.md §5 "Firmware executed") running
tiny programs compiled here with arm-none-eabi-gcc.

A fake peripheral (a real :class:`Peripheral` registered in the machine) takes the programs'
log words with the emulated time, pends IRQs when a test schedules them, and can pend an IRQ
at every slice boundary. What is expected comes from the ARMv7-M architecture (EXC_RETURN
values, preemption by priority, PRIMASK/BASEPRI masking, WFI) and from hand-computed results
of the programs; instruction addresses come from arm-none-eabi-objdump and nm, not from the
machine.
"""

from __future__ import annotations

import heapq
import re
import shutil
import subprocess
from pathlib import Path

import pytest

pytest.importorskip("unicorn")
pytest.importorskip("elftools")

from psmat.emulator import EmulationError, Machine, Peripheral, UnmodelledAccess  # noqa: E402

GCC = shutil.which("arm-none-eabi-gcc")
OBJDUMP = shutil.which("arm-none-eabi-objdump")
NM = shutil.which("arm-none-eabi-nm")
pytestmark = pytest.mark.skipif(GCC is None or OBJDUMP is None or NM is None,
                                reason="arm-none-eabi-gcc, -objdump and -nm (Debian gcc-arm-none-eabi, "
                                       "binutils-arm-none-eabi) not on PATH")

FAKE_BASE = 0x40007800      # a reserved APB1 slot of the STM32F103 (RM0008 table 3)
DONE = 0xE0D                # logged by the reset handler when main returns

LINKER_SCRIPT = """
ENTRY(Reset_Handler)
MEMORY { FLASH (rx) : ORIGIN = 0x08000000, LENGTH = 64K
         RAM (rwx)  : ORIGIN = 0x20000000, LENGTH = 20K }
SECTIONS {
  .isr_vector : { KEEP(*(.isr_vector)) } > FLASH
  .text : { *(.text*) *(.rodata*) . = ALIGN(4); } > FLASH
  _sidata = LOADADDR(.data);
  .data : { _sdata = .; *(.data*) . = ALIGN(4); _edata = .; } > RAM AT > FLASH
  .bss (NOLOAD) : { _sbss = .; *(.bss*) *(COMMON) . = ALIGN(4); _ebss = .; } > RAM
  .stack (NOLOAD) : { . = ALIGN(8); . += 2K; _estack = .; } > RAM
}
"""

# What every program includes (prog.h): the fake's registers, NVIC set-up, helpers.
HEADER = r"""
#include <stdint.h>
#define FAKE ((volatile uint32_t *)0x40007800u)
#define LOG(v) (FAKE[0] = (uint32_t)(v))
#define LOG_LR(v) (FAKE[2] = (uint32_t)(v))
#define NVIC_ISER ((volatile uint32_t *)0xE000E100u)
#define NVIC_IPR ((volatile uint8_t *)0xE000E400u)
static inline __attribute__((unused)) void enable_irq(unsigned irq, uint8_t priority)
{
    NVIC_IPR[irq] = priority;
    NVIC_ISER[irq / 32u] = 1u << (irq % 32u);
}
static inline __attribute__((unused)) uint32_t get_lr(void)
{
    uint32_t lr;
    __asm volatile("mov %0, lr" : "=r"(lr));
    return lr;
}
static __attribute__((unused)) void spin(volatile uint32_t n)
{
    while (n)
        n--;
}
"""

# Vector table with IRQ 0-9 at irq0..irq9 (weak: unused ones log 0xDEAD0000 and hang), .data
# copied from flash, .bss cleared, main called, DONE logged.
STARTUP = r"""
#include "prog.h"
extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);
void Default_Handler(void)
{
    LOG(0xDEAD0000u);
    for (;;) {
    }
}
#define WEAK __attribute__((weak, alias("Default_Handler")))
void irq0(void) WEAK; void irq1(void) WEAK; void irq2(void) WEAK; void irq3(void) WEAK;
void irq4(void) WEAK; void irq5(void) WEAK; void irq6(void) WEAK; void irq7(void) WEAK;
void irq8(void) WEAK; void irq9(void) WEAK;
void Reset_Handler(void)
{
    uint32_t *src = &_sidata, *dst = &_sdata;
    while (dst < &_edata)
        *dst++ = *src++;
    for (dst = &_sbss; dst < &_ebss;)
        *dst++ = 0;
    main();
    LOG(0xE0Du);
    for (;;) {
    }
}
typedef void (*vector)(void);
#define D Default_Handler
__attribute__((section(".isr_vector"), used)) static const vector vectors[16 + 43] = {
    (vector)&_estack, Reset_Handler, D, D, D, D, D, 0, 0, 0, 0, D, D, 0, D, D,
    irq0, irq1, irq2, irq3, irq4, irq5, irq6, irq7, irq8, irq9,
    D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D, D,
    D, D, D};
"""


class Fake(Peripheral):
    """A test device: LOG (0x0) records (word, now_s, instructions), PEND (0x4) pends an IRQ at
    once, LR (0x8) records a handler's EXC_RETURN; IRQs can be scheduled at emulated times or
    pended at every slice boundary (``stress``) where the IRQ is neither pending nor active and
    the PC moved since the last such pend (thread mode ran at least one instruction)."""

    name = "FAKE"
    base = FAKE_BASE
    size = 0x400

    def reset(self) -> None:
        self.log: list[tuple[int, float, int]] = []
        self.lrs: list[int] = []
        self.events: list[tuple[float, int]] = []
        self.on_log = None
        self.stress: int | None = None
        self._stress_pc: int | None = None

    @property
    def words(self) -> list[int]:
        return [w for w, _, _ in self.log]

    def at(self, word: int) -> tuple[float, int]:
        """(now_s, instructions) of the first log of ``word``."""
        return next((t, n) for w, t, n in self.log if w == word)

    def schedule(self, delay_s: float, irq: int) -> None:
        heapq.heappush(self.events, (self.machine.now_s + delay_s, irq))

    def read(self, offset: int, size: int) -> int:
        return super().read(offset, size)      # nothing readable: fails as unmodelled

    def write(self, offset: int, size: int, value: int) -> None:
        if offset == 0:
            self.log.append((value, self.machine.now_s, self.machine.instructions))
            if self.on_log is not None:
                self.on_log(self, value)
        elif offset == 4:
            self.machine.nvic.set_pending(value)
        elif offset == 8:
            self.lrs.append(value)
        else:
            super().write(offset, size, value)

    def _stress_due(self) -> bool:
        nvic = self.machine.nvic
        return (self.stress is not None and not nvic.is_pending(self.stress)
                and self.stress not in nvic.active_irqs and self.machine.pc != self._stress_pc)

    def next_event_s(self) -> float | None:
        if self._stress_due():
            return self.machine.now_s
        return self.events[0][0] if self.events else None

    def advance(self, now_s: float) -> None:
        while self.events and self.events[0][0] <= now_s:
            self.machine.nvic.set_pending(heapq.heappop(self.events)[1])
        if self._stress_due():
            self._stress_pc = self.machine.pc
            self.machine.nvic.set_pending(self.stress)


def run(cmd: list[str]) -> str:
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def build(tmp_path: Path, main_source: str, *defines: str) -> Path:
    """Compiles the startup and ``main_source`` for the Cortex-M3; returns the ELF."""
    (tmp_path / "link.ld").write_text(LINKER_SCRIPT)
    (tmp_path / "prog.h").write_text(HEADER)
    (tmp_path / "startup.c").write_text(STARTUP)
    src = tmp_path / "prog.c"
    src.write_text('#include "prog.h"\n' + main_source)
    elf = tmp_path / ("prog" + "".join(d.replace("=", "") for d in defines) + ".elf")
    run([GCC, "-mcpu=cortex-m3", "-mthumb", "-O1", "-std=gnu11", "-ffreestanding", "-nostdlib",
         "-Wall", "-Werror", *(f"-D{d}" for d in defines), "-T", str(tmp_path / "link.ld"),
         "-o", str(elf), str(tmp_path / "startup.c"), str(src), "-lgcc"])
    return elf


def function_range(elf: Path, name: str) -> range:
    """Addresses of function ``name``, from nm."""
    for line in run([NM, "-S", str(elf)]).splitlines():
        fields = line.split()
        if len(fields) == 4 and fields[3] == name:
            start = int(fields[0], 16) & ~1
            return range(start, start + int(fields[1], 16))
    raise AssertionError(f"{name} not in {elf}")


def instructions_of(elf: Path, name: str) -> list[tuple[int, str, str]]:
    """(address, mnemonic, operands) of function ``name``, from objdump."""
    out = run([OBJDUMP, "-d", f"--disassemble={name}", str(elf)])
    rows = []
    for m in re.finditer(r"^\s*([0-9a-f]+):\s+(?:[0-9a-f]{4}\s?){1,2}\s+(\S+)\s*([^\n;@]*)", out, re.M):
        rows.append((int(m.group(1), 16), m.group(2), m.group(3).strip()))
    return rows


# one instruction per slice: a stressing IRQ lands after every instruction of thread mode
ONE_INSTRUCTION_S = 1e-12


def machine(elf: Path, **kw) -> tuple[Machine, Fake]:
    m = Machine(elf, peripherals=[Fake], **kw)
    return m, m.peripheral("FAKE")


def run_to_done(m: Machine, fake: Fake, instructions: int = 2_000_000) -> None:
    m.run(until=lambda: DONE in fake.words, instructions=instructions)
    assert DONE in fake.words, (fake.words, hex(m.pc))


# -- unmodelled accesses --------------------------------------------------------------------------

UNMODELLED = r"""
typedef void (*fn)(void);
__attribute__((noinline)) uint32_t bad_read(void) { return *(volatile uint32_t *)0x40013C00u; }
__attribute__((noinline)) void bad_write(void) { *(volatile uint16_t *)0x40013C04u = 0x1234u; }
__attribute__((noinline)) void bad_flash_write(void) { *(volatile uint32_t *)0x08000000u = 0u; }
__attribute__((noinline)) int bad_fetch(void) { ((fn)0x30000001u)(); return 3; }
int main(void)
{
    if (CASE == 1) return (int)bad_read();
    if (CASE == 2) bad_write();
    if (CASE == 3) bad_flash_write();
    if (CASE == 4) return bad_fetch();
    return 0;
}
"""

PC_IN_MESSAGE = re.compile(r" at PC 0x([0-9A-F]{8}) \((\w+)\+0x[0-9A-F]+\)$")


@pytest.mark.parametrize("case, function, expected, mnemonic", [
    (1, "bad_read", "read of 4 bytes at 0x40013C00 (no model)", "ldr"),
    (2, "bad_write", "write of 2 bytes at 0x40013C04 (no model)", "strh"),
    (3, "bad_flash_write", "write of 4 bytes at 0x08000000 (flash is read-only)", "str"),
])
def test_unmodelled_access_names_address_size_and_pc(tmp_path: Path, case: int, function: str,
                                                     expected: str, mnemonic: str) -> None:
    """With the STM32F103's models in place (EXTI at 0x40013C00 has none): the exact
    address, size and kind, and the PC of the load/store instruction in the function doing it."""
    elf = build(tmp_path, UNMODELLED, f"CASE={case}")
    m = Machine(elf)
    with pytest.raises(UnmodelledAccess) as info:
        m.run(instructions=100_000)
    text = str(info.value)
    assert text.startswith(expected + " at PC 0x"), text
    pc = int(PC_IN_MESSAGE.search(text).group(1), 16)
    assert PC_IN_MESSAGE.search(text).group(2) == function
    assert pc in function_range(elf, function)
    accesses = [a for a, mn, ops in instructions_of(elf, function)
                if mn.split(".")[0] == mnemonic and "[pc" not in ops]
    assert accesses == [pc], (accesses, text)
    assert m.pc == pc


def test_unmodelled_fetch_names_address_and_caller(tmp_path: Path) -> None:
    elf = build(tmp_path, UNMODELLED, "CASE=4")
    m = Machine(elf)
    with pytest.raises(UnmodelledAccess, match=r"^instruction fetch at 0x30000000 \(no memory; LR "
                                               r"0x([0-9A-F]{8}), bad_fetch\+0x[0-9A-F]+\) at PC "
                                               r"0x30000000$") as info:
        m.run(instructions=100_000)
    lr = int(re.search(r"LR 0x([0-9A-F]{8})", str(info.value)).group(1), 16)
    calls = [a for a, mn, _ in instructions_of(elf, "bad_fetch") if mn == "blx"]
    assert calls == [(lr & ~1) - 2]


def test_unmodelled_register_of_the_system_control_space(tmp_path: Path) -> None:
    """SysTick (0xE000E010) has no model: the NVIC/SCB model fails it like any hole."""
    source = ("__attribute__((noinline)) uint32_t systick_value(void)\n"
              "{ return *(volatile uint32_t *)0xE000E018u; }\n"
              "int main(void) { return (int)systick_value(); }\n")
    m, _ = machine(build(tmp_path, source))
    with pytest.raises(UnmodelledAccess, match=r"^read of 4 bytes at 0xE000E018 \(no model in the NVIC/SCB\) "
                                               r"at PC 0x[0-9A-F]{8} \(systick_value\+0x"):
        m.run(instructions=10_000)


# -- interrupts -------------------------------------------------------------------------------------

REGISTERS = r"""
volatile uint32_t ticks;
volatile uint32_t magic = 0xC0FFEE01u;             /* .data: loaded into flash, copied by reset */
__attribute__((noinline)) void scramble(void) { __asm volatile("" ::: "memory"); }
void irq5(void)
{
    LOG_LR(get_lr());
    ticks++;
    /* clobber every caller-saved register and the flags (Z = 0, N = 1) */
    __asm volatile("movs r0, #0xA0\n movs r1, #0xA1\n movs r2, #0xA2\n movs r3, #0xA3\n"
                   "mov r12, r0\n movs r0, #0\n subs r0, #1\n" ::: "r0", "r1", "r2", "r3", "r12", "cc");
    scramble();                                      /* and LR */
}
/* Loads R0-R3, R12 and LR with known words and checks them (and the flags of each compare)
 * n times; returns 1 when they always held, 0 at the first difference. */
__attribute__((naked, noinline)) uint32_t check_registers(uint32_t n)
{
    __asm volatile(
        "push {r4, r7, lr}\n"                           /* SP = 4 mod 8 for the interrupts */
        "mov r7, r0\n"
        "ldr r0, =0x10101010\n ldr r1, =0x21212121\n ldr r2, =0x32323232\n"
        "ldr r3, =0x43434343\n ldr r4, =0x5C5C5C5C\n mov r12, r4\n ldr r4, =0x6E6E6E6E\n mov lr, r4\n"
        "1:\n"
        "ldr r4, =0x10101010\n cmp r0, r4\n bne 2f\n"
        "ldr r4, =0x21212121\n cmp r1, r4\n bne 2f\n"
        "ldr r4, =0x32323232\n cmp r2, r4\n bne 2f\n"
        "ldr r4, =0x43434343\n cmp r3, r4\n bne 2f\n"
        "ldr r4, =0x5C5C5C5C\n cmp r12, r4\n bne 2f\n"
        "ldr r4, =0x6E6E6E6E\n cmp lr, r4\n bne 2f\n"
        "subs r7, #1\n bne 1b\n"
        "movs r0, #1\n b 3f\n"
        "2:\n movs r0, #0\n"
        "3:\n pop {r4, r7, lr}\n bx lr\n"
        ".ltorg\n");
}
int main(void)
{
    LOG(magic);
    enable_irq(5, 0x80);
    uint32_t sp_before, sp_after;
    __asm volatile("mov %0, sp" : "=r"(sp_before));
    LOG(0x100);                                      /* the test starts pending IRQ 5 */
    uint32_t ok = check_registers(N);
    LOG(0x101);
    __asm volatile("mov %0, sp" : "=r"(sp_after));
    LOG(ok);
    LOG(ticks);
    LOG(sp_after - sp_before);
    return 0;
}
"""


def test_irq_handler_runs_and_returns_with_registers_intact(tmp_path: Path) -> None:
    """IRQ 5 pended at every slice boundary while main checks R0-R3, R12, LR and the flags:
    the handler (which clobbers all of them) runs many times and thread mode never sees it."""
    iterations = 60
    elf = build(tmp_path, REGISTERS, f"N={iterations}")
    m, fake = machine(elf, max_slice_s=ONE_INSTRUCTION_S)

    def on_log(fake: Fake, word: int) -> None:
        fake.stress = 5 if word == 0x100 else None

    fake.on_log = on_log
    run_to_done(m, fake)
    words = fake.words
    assert words[0] == 0xC0FFEE01                    # .data loaded at its load address, copied
    assert words[1:4] == [0x100, 0x101, 1], words    # all registers held
    ticks = words[4]
    # an interrupt after every instruction of main: 20 per iteration of the loop
    assert ticks >= 20 * iterations, ticks
    assert fake.lrs == [0xFFFFFFF9] * ticks          # EXC_RETURN: back to thread mode, MSP
    assert words[5] == 0                             # SP back where it was (4-byte padding undone)
    assert m.nvic.active_irqs == () and m.reg("IPSR") == 0


NESTING = r"""
volatile uint32_t done1, done2;
void irq1(void)                                      /* priority 0xC0 (low) */
{
    LOG(0x11);
    LOG_LR(get_lr());
    spin(400);
    LOG(0x1F);
    done1++;
}
void irq2(void)                                      /* priority 0x40 (high) */
{
    LOG(0x21);
    LOG_LR(get_lr());
    spin(400);
    LOG(0x2F);
    done2++;
}
int main(void)
{
    enable_irq(1, 0xC0);
    enable_irq(2, 0x40);
    LOG(0x100);                        /* phase 1: IRQ 1, then IRQ 2 while its handler runs */
    while (done1 < 1 || done2 < 1) {
    }
    LOG(0x200);                        /* phase 2: IRQ 2, then IRQ 1 while its handler runs */
    while (done1 < 2 || done2 < 2) {
    }
    return 0;
}
"""


def test_nesting_by_priority(tmp_path: Path) -> None:
    """A higher-priority IRQ preempts a running lower one (LR 0xFFFFFFF1 in the nested
    handler); a lower one waits for the higher handler to return."""
    m, fake = machine(build(tmp_path, NESTING))
    phase = {"n": 0}

    def on_log(fake: Fake, word: int) -> None:
        if word in (0x100, 0x200):
            phase["n"] = word
            fake.schedule(10e-6, 1 if word == 0x100 else 2)
        elif word == 0x11 and phase["n"] == 0x100:
            fake.schedule(10e-6, 2)
        elif word == 0x21 and phase["n"] == 0x200:
            fake.schedule(10e-6, 1)

    fake.on_log = on_log
    run_to_done(m, fake)
    assert fake.words == [0x100, 0x11, 0x21, 0x2F, 0x1F,
                          0x200, 0x21, 0x2F, 0x11, 0x1F, DONE]
    assert fake.lrs == [0xFFFFFFF9, 0xFFFFFFF1, 0xFFFFFFF9, 0xFFFFFFF9]


MASKING = r"""
void irq3(void) { LOG(0x33); }                       /* priority 0x80 */
void irq4(void) { LOG(0x44); }                       /* priority 0x40 */
int main(void)
{
    enable_irq(3, 0x80);
    enable_irq(4, 0x40);
    __asm volatile("cpsid i" ::: "memory");
    LOG(0x300);                                      /* IRQ 3 pends 10 us later */
    spin(500);
    LOG(0x301);
    __asm volatile("cpsie i" ::: "memory");
    spin(50);
    LOG(0x302);
    __asm volatile("msr basepri, %0" : : "r"(0x80u) : "memory");
    LOG(0x400);                                      /* IRQ 3 at 10 us, IRQ 4 at 20 us */
    spin(500);
    LOG(0x401);
    __asm volatile("msr basepri, %0" : : "r"(0u) : "memory");
    spin(50);
    LOG(0x402);
    return 0;
}
"""


def test_primask_and_basepri_hold_off_interrupts(tmp_path: Path) -> None:
    """PRIMASK holds IRQ 3 off until CPSIE; BASEPRI 0x80 holds off priority 0x80 (IRQ 3)
    but not 0x40 (IRQ 4)."""
    m, fake = machine(build(tmp_path, MASKING))

    def on_log(fake: Fake, word: int) -> None:
        if word == 0x300:
            fake.schedule(10e-6, 3)
        elif word == 0x400:
            fake.schedule(10e-6, 3)
            fake.schedule(20e-6, 4)

    fake.on_log = on_log
    run_to_done(m, fake)
    assert fake.words == [0x300, 0x301, 0x33, 0x302, 0x400, 0x44, 0x401, 0x33, 0x402, DONE]
    # the masked interrupt was pending for the whole spin, not scheduled late
    assert fake.at(0x301)[0] - fake.at(0x300)[0] > 10e-6


IT_BLOCKS = r"""
volatile uint32_t ticks;
void irq7(void)
{
    ticks++;
    __asm volatile("movs r0, #0\n cmp r0, #1\n" ::: "r0", "cc");   /* Z = 0, C = 0, N = 1 */
}
/* sum over i < n of (i % 4 == 1 ? 100 : 3) + (i % 4 != 2 ? 1006 : 0), in IT blocks */
__attribute__((naked, noinline)) uint32_t it_sum(uint32_t n)
{
    __asm volatile(
        "push {r4-r6}\n movs r4, #0\n movs r5, #0\n"
        "1:\n"
        "and r6, r5, #3\n"
        "cmp r6, #1\n"
        "itee eq\n addeq r4, r4, #100\n addne r4, r4, #1\n addne r4, r4, #2\n"
        "cmp r6, #2\n"
        "ittt ne\n addne r4, r4, #10\n subne r4, r4, #4\n addne r4, r4, #1000\n"
        "adds r5, #1\n cmp r5, r0\n bne 1b\n"
        "mov r0, r4\n pop {r4-r6}\n bx lr\n");
}
int main(void)
{
    enable_irq(7, 0x80);
    LOG(0x700);
    uint32_t sum = it_sum(N);
    LOG(0x701);
    LOG(sum);
    LOG(ticks);
    return 0;
}
"""


def test_interrupts_never_land_inside_an_it_block(tmp_path: Path) -> None:
    """IRQ 7 (which clobbers the flags) pended at every slice boundary while main sums in IT
    blocks: an interrupt inside a block would lose its IT state and corrupt the sum."""
    n = 64
    m, fake = machine(build(tmp_path, IT_BLOCKS, f"N={n}"), max_slice_s=ONE_INSTRUCTION_S)
    fake.on_log = lambda fake, word: setattr(fake, "stress", 7 if word == 0x700 else None)
    run_to_done(m, fake)
    expected = sum((100 if i % 4 == 1 else 3) + (1006 if i % 4 != 2 else 0) for i in range(n))
    words = fake.words
    assert words[:3] == [0x700, 0x701, expected], words
    # an interrupt after every instruction and IT block of the loop (8 per iteration)
    assert words[3] >= 8 * n, words


WFI = r"""
volatile uint32_t seen;
void irq6(void)
{
    LOG(0x66);
    seen++;
}
int main(void)
{
    enable_irq(6, 0x80);
    LOG(0x600);                                      /* IRQ 6 pends 5 ms later */
    __asm volatile("wfi");
    LOG(0x601);
    __asm volatile("cpsid i" ::: "memory");
    LOG(0x700);                                      /* again, with PRIMASK set */
    __asm volatile("wfi");
    LOG(0x701);                                      /* woken, the handler not yet run */
    __asm volatile("cpsie i" ::: "memory");
    spin(50);
    LOG(0x702);
    /* the firmware's idle loop: the unmasked window is two instructions, after the WFI */
    LOG(0x800);
    while (seen < 3) {
        __asm volatile("cpsid i" ::: "memory");
        if (seen < 3)
            __asm volatile("wfi");
        __asm volatile("cpsie i" ::: "memory");
    }
    LOG(0x801);
    __asm volatile("wfi");                           /* nothing to come */
    LOG(0x703);
    return 0;
}
"""


def test_wfi_skips_time_to_the_next_event(tmp_path: Path) -> None:
    m, fake = machine(build(tmp_path, WFI))
    delay = 5e-3

    def on_log(fake: Fake, word: int) -> None:
        if word in (0x600, 0x700, 0x800):
            fake.schedule(delay, 6)

    fake.on_log = on_log
    m.run(until=lambda: 0x801 in fake.words, instructions=1_000_000)
    assert fake.words == [0x600, 0x66, 0x601, 0x700, 0x701, 0x66, 0x702, 0x800, 0x66, 0x801]
    for start, woken in ((0x600, 0x66), (0x700, 0x701)):
        (t0, n0), (t1, n1) = fake.at(start), fake.at(woken)
        assert t1 >= t0 + delay                      # not before the event
        assert n1 - n0 < 200                         # slept through it, not executed it
    # asleep with nothing to come: a time limit is reached in WFI, anything else fails
    m.run(until_s=1.0)
    assert m.sleeping and m.now_s == pytest.approx(1.0) and fake.words[-1] == 0x801
    with pytest.raises(EmulationError, match=r"^WFI with no interrupt to come .* at PC 0x[0-9A-F]{8} \(main"):
        m.run(instructions=1000)


def test_no_exception_entry_while_the_cpu_is_inside_an_it_block(tmp_path: Path) -> None:
    """Unicorn's instruction count never ends a slice inside an IT block (so the test above
    cannot reach one); stopped inside one on purpose (unicorn's ``until`` address, the machine's
    private handle), the machine defers a pending, enabled IRQ until the block is done."""
    from unicorn.arm_const import UC_ARM_REG_R0

    m, fake = machine(build(tmp_path, IT_BLOCKS, "N=64"))
    m.nvic.enabled |= 1 << 7
    body = instructions_of(m.image.path, "it_sum")
    itee = next(a for a, mn, _ in body if mn == "itee")
    inside = next(a for a, mn, _ in body if a > itee)          # the block's first instruction
    m.run(until=lambda: 0x700 in fake.words, instructions=100_000)
    m._uc.emu_start(m.pc | 1, inside)                          # into it_sum, up to the block
    m._uc.emu_start(m.pc | 1, inside + 2)                      # one instruction into the block
    assert m.reg("XPSR") & 0x0600FC00                          # EPSR IT bits: inside
    m.nvic.set_pending(7)
    assert not m.nvic.take_pending() and m.nvic.active_irqs == ()
    m._uc.emu_start(m.pc | 1, 0xFFFFFFFF, 0, 2)                # the rest of the block
    assert not m.reg("XPSR") & 0x0600FC00
    assert m.nvic.take_pending() and m.nvic.active_irqs == (7,)
    assert m._uc.reg_read(UC_ARM_REG_R0) == 64                 # n, untouched
