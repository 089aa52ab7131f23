"""An independent bit-serial CRC-16/CCITT-FALSE for the protocol tests (not the code under test)."""


def crc_bitwise(data: bytes) -> int:
    """Bit-serial CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, MSB first, no reflection, no xorout."""
    reg = 0xFFFF
    for byte in data:
        for i in range(7, -1, -1):
            feedback = ((reg >> 15) & 1) ^ ((byte >> i) & 1)
            reg = (reg << 1) & 0xFFFF
            if feedback:
                reg ^= 0x1021
    return reg
