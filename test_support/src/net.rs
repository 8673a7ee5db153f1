//! Loopback addresses for tests, their ports always from the OS.

use std::net::{Ipv4Addr, SocketAddr};

use socket2::{Domain, Socket, Type};

/// A loopback TCP address where nothing listens: a connect there is
/// refused. The port stays bound (never listening) by the returned socket,
/// so nothing else can take it while the test runs; a port bound and freed
/// again to find a free one could be taken by then.
pub fn refusing_address() -> (Socket, SocketAddr) {
    let socket = Socket::new(Domain::IPV4, Type::STREAM, None).expect("a TCP socket");
    socket
        .bind(&SocketAddr::from((Ipv4Addr::LOCALHOST, 0)).into())
        .expect("bind 127.0.0.1:0");
    let address = socket
        .local_addr()
        .expect("its address")
        .as_socket()
        .expect("an IP address");
    (socket, address)
}

#[cfg(test)]
mod tests {
    use std::io::ErrorKind;
    use std::net::TcpStream;

    use super::*;

    #[test]
    fn a_connect_is_refused_while_the_socket_holds_the_port() {
        let (_held, address) = refusing_address();
        assert_ne!(address.port(), 0);
        let error = TcpStream::connect(address).expect_err("nothing listens");
        assert_eq!(error.kind(), ErrorKind::ConnectionRefused);
    }
}
