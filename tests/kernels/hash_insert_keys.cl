// Test kernel of the lock-free hash (kernels/hash_table.cl): inserts `n` keys, recording each key's
// slot, so that the tests can put the table under heavy duplication. Built only into the tests'
// program (support/test_kernels.hpp), after contract.h and hash_table.cl.
__kernel void hash_insert_keys(__global const ulong* in, uint n, volatile __global ulong* keys, ulong capacity,
                               __global long* slot_of, volatile __global int* stats) {
    uint i = get_global_id(0);
    if (i >= n) return;
    slot_of[i] = hash_insert_counted(keys, capacity, in[i], stats);
}
