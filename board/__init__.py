"""The board: what the engine needs around it on an FPGA board (the ULX3S-85F): the display's video timing and DVI
output, the UART command receiver, the board top. Layered above ``rtl`` (it instantiates the engine) and below
``cosim`` (whose testbenches drive it)."""
