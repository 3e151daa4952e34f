//! Enumeration: the descriptors are what `gonio ports` matches (brdf-core's identity),
//! the endpoints are those the bus allocated, and the CDC class requests work.

use brdf_core::identity::{USB_MANUFACTURER, USB_PID, USB_PRODUCT, USB_VID};
use gonio::device::ports::{Likeness, PortRow, find_by_usb_serial};
use serialport::{SerialPortInfo, SerialPortType, UsbPortInfo};
use usb_device::endpoint::EndpointType;
use usb_link::MAX_PACKET;

use super::host::{DTR, LINE_CODING, RTS};
use super::rig::{Rig, SERIAL};

#[test]
fn descriptors_are_what_gonio_ports_matches() {
    let mut rig = Rig::new();
    let cdc = rig.enumerate();
    assert_eq!(cdc.vid_pid(), (USB_VID, USB_PID));
    assert_eq!(cdc.device[4], usbd_serial::USB_CLASS_CDC, "device class");
    let [manufacturer, product, serial] = cdc.strings.clone();
    assert_eq!(manufacturer.as_deref(), Some(USB_MANUFACTURER));
    assert_eq!(product.as_deref(), Some(USB_PRODUCT));
    assert_eq!(serial.as_deref(), Some(SERIAL));

    // What the system would list for it, as gonio ports reads it.
    let info = SerialPortInfo {
        port_name: "/dev/ttyACM0".into(),
        port_type: SerialPortType::UsbPort(UsbPortInfo {
            vid: cdc.vid_pid().0,
            pid: cdc.vid_pid().1,
            serial_number: serial,
            manufacturer,
            product,
            interface: Some(cdc.comm_interface),
        }),
    };
    let row = PortRow::from_info(&info);
    assert_eq!(row.gonio, Likeness::Yes, "{row:?}");
    // The lines firmware/README.md's bring-up shows.
    assert_eq!(
        gonio::cli::ports::table(&[row]),
        "  PORT          TYPE  VID:PID    MANUFACTURER  PRODUCT           SERIAL\n\
         * /dev/ttyACM0  usb   16c0:27dd  gonio         gonio goniometer  3A0047001851393038353133\n\
         * looks like the gonio firmware (product \"gonio goniometer\")\n"
    );
    let infos = [info];
    assert_eq!(
        find_by_usb_serial(&infos, SERIAL).map(|p| p.port_name.as_str()),
        Some("/dev/ttyACM0"),
        "a lost device is found again by its serial number"
    );
}

#[test]
fn endpoints_are_the_ones_described_and_class_requests_work() {
    let mut rig = Rig::new();
    let cdc = rig.enumerate();
    assert_eq!(
        (cdc.bulk_in.max, cdc.bulk_out.max),
        (MAX_PACKET, MAX_PACKET)
    );
    {
        let s = rig.wire.state();
        let at = |a: u8| usize::from(a & 0x0F);
        let inn = |a: u8| s.inn[at(a)].as_ref().expect("IN endpoint allocated");
        let out = s.out[at(cdc.bulk_out.address)]
            .as_ref()
            .expect("OUT endpoint allocated");
        assert_eq!(inn(cdc.bulk_in.address).ty, EndpointType::Bulk);
        assert_eq!(inn(cdc.bulk_in.address).max, cdc.bulk_in.max);
        assert_eq!((out.ty, out.max), (EndpointType::Bulk, cdc.bulk_out.max));
        assert!(matches!(
            inn(cdc.notify.address).ty,
            EndpointType::Interrupt
        ));
    }

    rig.set_line_coding(&LINE_CODING);
    assert_eq!(rig.get_line_coding(), LINE_CODING);
    assert!(!rig.link.host_open());
    rig.set_control_lines(DTR | RTS);
    assert!(rig.link.host_open(), "DTR raised");
    rig.set_control_lines(0);
    assert!(!rig.link.host_open(), "DTR dropped");
    // Closing resets the port's state, line coding included (9600 8N1; the firmware
    // ignores it, and hosts set it again on every open).
    assert_eq!(rig.get_line_coding(), [0x80, 0x25, 0, 0, 0, 0, 8]);
    // The notification endpoint is polled and has nothing to say.
    assert_eq!(rig.poll_notify(), None);
    // A request the device does not support is stalled, and EP0 works afterwards.
    assert!(rig.control_in(0xA1, 0x7F, 0, 0, 4).is_err());
    rig.set_line_coding(&LINE_CODING);
    assert_eq!(rig.get_line_coding(), LINE_CODING);
}
