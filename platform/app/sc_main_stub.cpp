// libsystemc provides main() and calls sc_main(); xbarsim has its own main() and
// elaborates SystemC on demand (xbarsim simulate), so this is never called.
#include <systemc>

int sc_main(int, char*[]) { return 1; }
