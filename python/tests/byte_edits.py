"""Byte-level edits for the readers' differential tests: a file's bytes with a
few of them replaced, inserted or removed, drawn from an alphabet that the
reader under test finds meaningful (plus one random byte)."""


def mutated(rng, data, alphabet):
    """data with one to three bytes replaced, inserted or removed."""
    b = bytearray(data)
    for _ in range(rng.randint(1, 3)):
        i = rng.randrange(len(b) + 1)
        op = rng.randrange(3)
        byte = rng.choice(alphabet + bytes([rng.randrange(256)]))
        if op == 0 and i < len(b):
            b[i] = byte
        elif op == 1:
            b.insert(i, byte)
        elif i < len(b):
            del b[i]
    return bytes(b)
