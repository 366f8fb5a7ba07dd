// color_field.cl (to be written)
