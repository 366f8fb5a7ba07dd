// scalar_field.cl (to be written)
