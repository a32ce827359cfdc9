#!/usr/bin/env python3
"""Charge a callgrind profile's instructions to stages: scripts/stages.sh's second half.

    stages.py CALLGRIND_OUT BINARY ITEMS STAGE[,STAGE...]

CALLGRIND_OUT must come from `valgrind --tool=callgrind --dump-instr=yes`, BINARY must carry line
tables. Every instruction of BINARY is charged to the innermost function of the STAGE list among
the functions it was inlined into (`addr2line -i`: inlined frames resolved, so a stage inlined
into its caller is still its own); an instruction in none of them to `(other) F`, F the innermost
of its functions from the project's sources (not the standard library's). Instructions of other objects (Embree, libc) are charged to the object. Prints a
Markdown table of instructions per item (ITEMS: the rays or tests the run counted).
"""
import collections
import re
import subprocess
import sys


def costs_by_address(path):
    """Self cost per (object, address): the cost lines of a --dump-instr=yes profile, with
    callgrind's relative positions (`+N`, `-N`, `*`) resolved and call costs skipped."""
    cost = collections.Counter()
    objects, obj, addr, after_call = {}, None, 0, False
    position = re.compile(r'^(0x[0-9a-fA-F]+|[+-]\d+|\*)$')
    for line in open(path):
        if line.startswith(('ob=', 'cob=')):
            m = re.match(r'^c?ob=\((\d+)\)(?: (.*))?$', line.rstrip('\n'))
            if m.group(2):
                objects[m.group(1)] = m.group(2)
            if line.startswith('ob='):
                obj = objects.get(m.group(1))
            continue
        if line.startswith('calls='):
            after_call = True  # the next cost line is the call's inclusive cost
            continue
        fields = line.split()
        if len(fields) < 3 or not position.match(fields[0]):
            continue
        tok = fields[0]
        if tok.startswith('0x'):
            addr = int(tok, 16)
        elif tok[0] in '+-':
            addr += int(tok)
        if after_call:
            after_call = False
            continue
        cost[(obj, addr)] += int(fields[-1])
    return cost


def inline_chains(binary, addresses):
    """The functions at each address, innermost first, as (name, whether its source is the
    project's own rather than the standard library's): addr2line -i -f -C."""
    out = subprocess.run(['addr2line', '-e', binary, '-a', '-i', '-f', '-C'] + [hex(a) for a in addresses],
                         capture_output=True, text=True, check=True).stdout.splitlines()
    chains, cur, i = {}, None, 0
    while i < len(out):
        if re.match(r'^0x[0-9a-f]+$', out[i]):
            cur = int(out[i], 16)
            chains[cur] = []
            i += 1
        else:
            own = i + 1 < len(out) and not out[i + 1].startswith(('/rustc/', '??'))
            chains[cur].append((short_name(out[i]), own))
            i += 2  # the name, then its file:line
    # An inlined closure has only its own name: put the function it is in before it.
    for chain in chains.values():
        for j in range(len(chain) - 2, -1, -1):
            if chain[j][0].startswith('{'):
                chain[j] = (chain[j + 1][0] + '::' + chain[j][0], chain[j][1])
    return chains


def short_name(name):
    """The last path segment of a demangled name, generics and closures' paths dropped."""
    while '<' in name:
        stripped = re.sub(r'<[^<>]*>', '', name)
        if stripped == name:
            break
        name = stripped
    parts = name.split(' ')[0].split('::')
    # A closure under the function it is in.
    name = '::'.join(parts[-2:]) if parts[-1].startswith('{') and len(parts) > 1 else parts[-1]
    # A function multiversioned at run time, under the name of the version the CPU ran.
    return re.sub(r'_(default|x86_64|avx2|sse4_1|fma)[a-z0-9_]*_version$', '', name)


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    profile, binary, items, stages = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split(',')
    cost = costs_by_address(profile)
    ours = sorted(a for (o, a) in cost if o and o.endswith(binary.split('/')[-1]))
    chains = inline_chains(binary, ours)
    charged = collections.Counter()
    for (obj, addr), c in cost.items():
        if not (obj and obj.endswith(binary.split('/')[-1])):
            charged['(object) ' + (obj or '?').split('/')[-1]] += c
            continue
        chain = chains.get(addr) or [('?', True)]
        stage = next((f for f, _ in chain if f in stages), None)
        own = next((f for f, mine in chain if mine), chain[0][0])
        charged[stage or '(other) ' + own] += c
    total = sum(charged.values())
    print(f'| stage | instructions per item | share |')
    print('|---|---|---|')
    for stage, c in charged.most_common():
        if c / items >= 1.0:
            print(f'| {stage} | {c / items:.1f} | {100.0 * c / total:.1f}% |')
    print(f'| all | {total / items:.1f} | 100% |')


if __name__ == '__main__':
    main()
