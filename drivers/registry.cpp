// Backends register themselves by name in the factories of their device kind;
// this translation unit anchors the library.
namespace hg::drivers {
int driversLibraryAnchor = 0;
}
