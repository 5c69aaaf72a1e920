// A shared library that is not a hedgefit plugin: it lacks hedgefit_plugin_entry.
extern "C" int not_a_hedgefit_plugin() { return 42; }
