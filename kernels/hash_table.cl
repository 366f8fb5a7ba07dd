// hash_table.cl (to be written)
