; ATmega4809 reset and vector table (40 vectors of one JMP each, datasheet "Interrupt Vector
; Mapping"). Unused vectors fall through to __bad_interrupt (a visible hang). Reset: zero
; register, copy .data from flash, clear .bss, call main. SP is RAMEND after reset.

    .macro vector n
    .weak __vector_\n
    .set __vector_\n, __bad_interrupt
    jmp __vector_\n
    .endm

    .section .vectors, "ax", @progbits
    .global __vectors
__vectors:
    jmp __reset
    .irp n, 1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17,18,19,20,21,22,23,24,25,26,27,28,29,30,31,32,33,34,35,36,37,38,39
    vector \n
    .endr

    .text
__bad_interrupt:
    rjmp __bad_interrupt

__reset:
    clr r1
    out 0x3F, r1                ; SREG
    ldi r26, lo8(__data_start)  ; X: .data in RAM
    ldi r27, hi8(__data_start)
    ldi r30, lo8(__data_load_start) ; Z: its image in flash
    ldi r31, hi8(__data_load_start)
    rjmp 2f
1:  lpm r0, Z+
    st X+, r0
2:  cpi r26, lo8(__data_end)
    ldi r24, hi8(__data_end)
    cpc r27, r24
    brne 1b
    ldi r26, lo8(__bss_start)
    ldi r27, hi8(__bss_start)
    rjmp 4f
3:  st X+, r1
4:  cpi r26, lo8(__bss_end)
    ldi r24, hi8(__bss_end)
    cpc r27, r24
    brne 3b
    call main
5:  rjmp 5b
